#!/usr/bin/env bash
# Installs what is missing, builds rigfit and runs the whole test suite with ctest.
#   scripts/test.sh              Release build in build/ (or $RIGFIT_BUILD_DIR)
#   scripts/test.sh --sanitize   the same suite built with AddressSanitizer +
#                                UndefinedBehaviorSanitizer in build-asan/ (or
#                                $RIGFIT_ASAN_BUILD_DIR), benchmarks and the tests labelled
#                                long (tests/long_tests.txt) left out; any finding fails
#                                its test (docs/reliability.md)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
sanitize=0
for arg in "$@"; do
  case "$arg" in
    --sanitize) sanitize=1 ;;
    *)
      echo "usage: scripts/test.sh [--sanitize]" >&2
      exit 2
      ;;
  esac
done
"$root/scripts/setup.sh"
if [ "$sanitize" -eq 0 ]; then
  "$root/scripts/build.sh"
  cd "${RIGFIT_BUILD_DIR:-$root/build}"
  ctest --output-on-failure -j2
else
  build="${RIGFIT_ASAN_BUILD_DIR:-$root/build-asan}"
  RIGFIT_BUILD_DIR="$build" "$root/scripts/build.sh" -DRIGFIT_SANITIZE=ON -DRIGFIT_BUILD_BENCH=OFF
  cd "$build"
  export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:check_initialization_order=1:strict_init_order=1}"
  export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1}"
  export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$root/scripts/lsan_suppressions.txt}"
  ctest --output-on-failure -j2 --label-exclude long
fi
