#!/usr/bin/env bash
# Configures and builds rigfit (Release, -j2) in build/ (or $RIGFIT_BUILD_DIR).
# Extra arguments are passed to CMake's configure step.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${RIGFIT_BUILD_DIR:-$root/build}"
# ccache (scripts/setup.sh installs it) keeps compiled objects between builds; with the
# repository root as its base directory a fresh clone elsewhere reuses them too.
launcher=()
if command -v ccache >/dev/null; then
  export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$root}"
  launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release "${launcher[@]}" "$@" >/dev/null
cmake --build "$build" -j2
