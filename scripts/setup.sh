#!/usr/bin/env bash
# Installs every Debian 12 package kcrig needs to build, test and benchmark.
# Idempotent: packages already present are left alone; runs as root (or via sudo).
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git clang-format ccache file
  libeigen3-dev libceres-dev libnlopt-dev libnlopt-cxx-dev libmodbus-dev
  libopenmpi-dev openmpi-bin slurmctld slurmd slurm-client munge
  libyaml-cpp-dev libcli11-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libsundials-dev can-utils minpack-dev libmatio-dev zlib1g-dev
  mbpoll socat python3-pymodbus python3-serial python3-serial-asyncio rt-tests
  qemu-system-x86 busybox-static cpio python3-can python3-canmatrix
  clang-14 libclang-rt-14-dev
  python3-plotly chromium fonts-dejavu-core python3-numpy python3-scipy python3-yaml
  libcivetweb-dev chromium-driver python3-selenium
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if ((${#missing[@]} == 0)); then
  echo "setup: all ${#packages[@]} packages present"
  exit 0
fi

sudo_cmd=()
if [[ $(id -u) -ne 0 ]]; then sudo_cmd=(sudo); fi
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup: done"
