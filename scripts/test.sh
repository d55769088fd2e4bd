#!/usr/bin/env bash
# The test suite: the same set-up as the demo, then every default test
# through ctest (long runs carry the ctest label "long" and are left out;
# run them with: ctest --test-dir build -L long), then the same suite again
# under AddressSanitizer and UndefinedBehaviorSanitizer with a minute of each
# fuzzer (scripts/sanitize.sh; skip it with WEAVEFIT_SKIP_SANITIZE=1).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/scripts/setup.sh"
ctest --test-dir "$root/build" --output-on-failure -j "$(nproc)" -LE long
if [ "${WEAVEFIT_SKIP_SANITIZE:-0}" != 1 ]; then
  "$root/scripts/sanitize.sh"
fi
