#!/usr/bin/env bash
# Quick start (1): installs the dependencies, builds kcrig (Release) and runs
# the main job: a 3-iteration campaign (estimate -> optimal design -> run ->
# estimate) on the embedded SIL rig, output in out/campaign/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
cmake --preset release >/dev/null
cmake --build --preset release --target kcrig
build/bin/kcrig campaign --out out/campaign "$@"
