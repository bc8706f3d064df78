#!/usr/bin/env bash
# The C++ package as a user meets it (ctest install_and_build_example, label package):
# installs this build into a fresh prefix, builds examples/cpp against it with
# find_package(rigfit), runs it (it exits non-zero unless the refinement brought the
# extrinsics closer to the truth) and, when PYTHON is set, imports the installed Python
# package from PREFIX/PYTHON_DIR.
#   install_and_build_example.sh BUILD_DIR SOURCE_DIR WORK_DIR [CMake arguments of the example]
set -euo pipefail
build="$1"
source="$2"
work="$3"
shift 3
# As scripts/build.sh: ccache (when the launcher is passed) shares objects across build trees.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$source}"

rm -rf "$work"
prefix="$work/prefix"
cmake --install "$build" --prefix "$prefix" >/dev/null
cmake -S "$source/examples/cpp" -B "$work/example" -DCMAKE_PREFIX_PATH="$prefix" "$@" >/dev/null
cmake --build "$work/example" -j2 >/dev/null
"$work/example/refine_in_memory"

if [ -n "${PYTHON:-}" ]; then
  module="$(PYTHONPATH="$prefix/$PYTHON_DIR" "$PYTHON" -c 'import rigfit; print(rigfit._rigfit.__file__)')"
  case "$module" in
    "$prefix/$PYTHON_DIR/rigfit/"*) echo "python: import rigfit -> $module" ;;
    *)
      echo "python: import rigfit found $module, not the module installed in $prefix" >&2
      exit 1
      ;;
  esac
fi
