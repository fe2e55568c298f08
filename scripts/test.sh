#!/usr/bin/env bash
# Quick start (2): installs the dependencies, builds Release and the
# AddressSanitizer + UBSan preset, and runs the test suite under both.
#   scripts/test.sh          CI tier (labels ci, ci-statistical, ci-heavy,
#                            ci-realtime); under the sanitizers the
#                            statistical and heavy ones (hundreds of seeded
#                            re-estimations, long profiles: numbers, not
#                            memory) and the real-time process tests (1 kHz
#                            deadlines) are left to Release
#   scripts/test.sh --full   every tier under both presets
set -euo pipefail
cd "$(dirname "$0")/.."
full=0
if [[ "${1:-}" == "--full" ]]; then full=1; fi

scripts/setup.sh
start=$SECONDS
for preset in release asan; do
  echo "== ${preset}: configure and build"
  cmake --preset "$preset" >/dev/null
  cmake --build --preset "$preset"
  echo "== ${preset}: test"
  if ((full)); then
    ctest --preset "$preset"
  elif [[ "$preset" == asan ]]; then
    ctest --preset "$preset" -L ci -LE 'statistical|heavy|realtime'
  else
    ctest --preset "$preset" -L ci
  fi
done
echo "== tests done in $((SECONDS - start)) s"
