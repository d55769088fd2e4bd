#!/usr/bin/env bash
# The main job: set up and build, start weavefitd on 127.0.0.1 (a free
# port), submit every photograph in fixtures/ with the client, print the
# result table, and stop the daemon.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/scripts/setup.sh"

work=$(mktemp -d)
daemon_pid=""
cleanup() {
  if [ -n "$daemon_pid" ] && kill -0 "$daemon_pid" 2>/dev/null; then
    kill -TERM "$daemon_pid"
    wait "$daemon_pid" || true
  fi
  rm -rf "$work"
}
trap cleanup EXIT

"$root/build/server/weavefitd" --listen 127.0.0.1:0 --port-file "$work/port" 2>"$work/weavefitd.log" &
daemon_pid=$!
for _ in $(seq 1 100); do
  [ -s "$work/port" ] && break
  kill -0 "$daemon_pid" 2>/dev/null || { cat "$work/weavefitd.log" >&2; exit 1; }
  sleep 0.1
done
[ -s "$work/port" ] || { echo "demo: weavefitd did not start" >&2; cat "$work/weavefitd.log" >&2; exit 1; }
port=$(head -n 1 "$work/port")
echo "weavefitd serving on 127.0.0.1:$port"
echo
shopt -s nullglob
cd "$root/fixtures"
"$root/build/client/weavefit" submit --server "127.0.0.1:$port" *.png *.tiff *.exr *.jpg
echo
echo "daemon log:"
sed 's/^/  /' "$work/weavefitd.log"
