#!/usr/bin/env bash
# Quick start (2): installs the dependencies, builds Release and the
# AddressSanitizer + UBSan preset, and runs the test suite under both.
#   scripts/test.sh          CI tier (ctest label "ci")
#   scripts/test.sh --full   every tier
set -euo pipefail
cd "$(dirname "$0")/.."
labels=(-L ci)
if [[ "${1:-}" == "--full" ]]; then labels=(); fi

scripts/setup.sh
start=$SECONDS
for preset in release asan; do
  echo "== ${preset}: configure and build"
  cmake --preset "$preset" >/dev/null
  cmake --build --preset "$preset"
  echo "== ${preset}: test"
  ctest --preset "$preset" "${labels[@]}"
done
echo "== tests done in $((SECONDS - start)) s"
