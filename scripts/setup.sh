#!/usr/bin/env bash
# Shared set-up of the two quick-start commands: installs the Debian packages
# weavefit needs (only those missing; sudo only when not root), then
# configures and builds into build/. Sourced by scripts/demo.sh and
# scripts/test.sh; safe to run again.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

packages=(
  cmake g++ make pkg-config
  libopencv-dev libceres-dev libopenexr-dev libflann-dev liblz4-dev libpng-dev
  libgrpc++-dev libgrpc-dev protobuf-compiler protobuf-compiler-grpc libprotobuf-dev
  libabsl-dev libgtest-dev libgmock-dev libbenchmark-dev libcli11-dev libgoogle-glog-dev
  libcivetweb-dev libssl-dev
  clang libclang-rt-14-dev
  gnuplot-nox
  python3-grpcio python3-grpc-tools python3-protobuf python3-numpy python3-pandas
  python3-venv python3-pip python3-setuptools python3-wheel
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  echo "setup: installing ${missing[*]}"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

cmake -S "$root" -B "$root/build" -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build "$root/build" -j "$(nproc)"
