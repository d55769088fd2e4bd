#!/usr/bin/env bash
# The whole test suite again under AddressSanitizer and
# UndefinedBehaviorSanitizer (clang, the "sanitize" preset in
# CMakePresets.json, built in build-sanitize/), including a minute of each
# libFuzzer target (ctest label "fuzz") and a replay of the committed fuzz
# corpus ("fuzz-corpus"). Long runs (label "long") stay out, as in test.sh.
# Called by scripts/test.sh after the default suite; assumes setup.sh ran.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
cmake --preset sanitize >/dev/null
cmake --build --preset sanitize -j "$(nproc)"
ctest --preset sanitize -j "$(nproc)"
