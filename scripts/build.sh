#!/usr/bin/env bash
# Configures and builds rigfit (Release, -j2) in build/ (or $RIGFIT_BUILD_DIR).
# Extra arguments are passed to CMake's configure step.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${RIGFIT_BUILD_DIR:-$root/build}"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
cmake --build "$build" -j2
