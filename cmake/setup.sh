#!/usr/bin/env bash
# Installs the Debian packages PolyFit needs (only those missing), then
# configures and builds build/ (Release, two jobs). Extra CMake arguments:
# POLYFIT_CMAKE_ARGS="-DPOLYFIT_NATIVE=OFF" bash cmake/setup.sh
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(cmake ninja-build g++ pkg-config
          libeigen3-dev libceres-dev libsuitesparse-dev libgoogle-glog-dev libgflags-dev
          libgtest-dev libgmock-dev libcgal-dev libassimp-dev libcli11-dev nlohmann-json3-dev libopencv-dev zlib1g-dev
          python3-dev python3-numpy python3-pytest python3-matplotlib pybind11-dev libopenmpi-dev openmpi-bin)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "Installing: ${missing[*]}"
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  $sudo apt-get update -q
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

generator=()
[ -f build/CMakeCache.txt ] || generator=(-G Ninja)
cmake -S . -B build "${generator[@]}" -DCMAKE_BUILD_TYPE=Release ${POLYFIT_CMAKE_ARGS:-}
cmake --build build -j2
