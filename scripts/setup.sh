#!/usr/bin/env bash
# Installs rigfit's build dependencies from Debian's packages. Idempotent: when every
# package is already installed it only checks and returns.
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  libceres-dev libeigen3-dev libsuitesparse-dev
  libhdf5-dev hdf5-tools
  libyaml-cpp-dev nlohmann-json3-dev libcli11-dev
  libnanoflann-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libopencv-calib3d-dev  # StereoSGBM for `rigfit simulate --depth-model stereo` (sim/ only)
  libpng-dev libcairo2-dev fonts-dejavu-core clang-format ccache
  pybind11-dev python3-dev python3-numpy python3-pytest  # the Python module (docs/python.md)
  chromium  # headless, for the tests that open a report's index.html and 3-D view
  libjs-three  # three.js, copied into every report's 3-D view (report/view3d.h)
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

echo "setup: installing ${missing[*]}" >&2
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
