#!/usr/bin/env bash
# Runs one libFuzzer target for SECONDS from the committed corpus SEEDS, with
# new inputs kept in a scratch folder (the committed corpus is not touched)
# and any crashing input saved under OUT as crash-*. Exit status non-zero on
# a crash, a leak, a timeout or a sanitizer report.
#   fuzz/run_fuzzer.sh FUZZER SEEDS SECONDS OUT
set -euo pipefail
fuzzer=$1 seeds=$2 seconds=$3 out=$4
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
name=$(basename "$fuzzer")
"$fuzzer" -max_total_time="$seconds" -timeout=30 -rss_limit_mb=4096 -max_len=1048576 \
  -artifact_prefix="$out/$name-" -print_final_stats=1 "$scratch" "$seeds" 2>"$scratch.log" || {
  status=$?
  tail -60 "$scratch.log"
  rm -f "$scratch.log"
  exit $status
}
grep -E "^(stat::number_of_executed_units|stat::peak_rss_mb|#[0-9]+ *DONE)" "$scratch.log" || true
echo "$name: $(ls "$scratch" | wc -l) new corpus inputs in ${seconds} s"
rm -f "$scratch.log"
