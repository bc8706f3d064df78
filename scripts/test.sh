#!/usr/bin/env bash
# Installs what is missing, builds rigfit and runs the whole test suite with ctest.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/setup.sh"
"$root/scripts/build.sh"
cd "${RIGFIT_BUILD_DIR:-$root/build}"
ctest --output-on-failure -j2
