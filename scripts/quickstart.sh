#!/usr/bin/env bash
# Quick start (1): installs the dependencies, builds kcrig (Release) and runs
# the main job: the paper's initial K&C experiment (phi = 85 deg,
# z_a = -0.45 m) on the simulated rig, written to out/quickstart/run.csv.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
cmake --preset release >/dev/null
cmake --build --preset release --target kcrig
mkdir -p out/quickstart
build/bin/kcrig simulate --out out/quickstart/run.csv "$@"
