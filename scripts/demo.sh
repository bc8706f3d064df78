#!/usr/bin/env bash
# rigfit end to end on a simulated rig: installs what is missing, builds, simulates a
# 4-camera rig into demo-out/ (capture, true and perturbed extrinsics), refines the perturbed
# extrinsics and evaluates them against the truth before and after refinement.
# Idempotent (demo-out/ is overwritten); fast once built. Exits non-zero if a step fails;
# a refinement that ran but was not applied (refine's exit code 3) is reported and the
# demo goes on.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${RIGFIT_BUILD_DIR:-$root/build}"

heading() { printf '\n===== %s =====\n' "$1"; }

# Runs build/cli/rigfit with the arguments, echoing the command first.
rigfit() {
  printf '$ rigfit %s\n' "$*"
  "$build/cli/rigfit" "$@"
}

heading "setup and build (scripts/setup.sh, scripts/build.sh)"
"$root/scripts/setup.sh"
"$root/scripts/build.sh"

cd "$root"
heading "simulate a rig"
rigfit simulate --out demo-out --force

heading "refine"
refine_status=0
rigfit refine --capture demo-out/capture.h5 --extrinsics demo-out/init.json \
  --out demo-out/refined.json || refine_status=$?
if [ "$refine_status" -eq 3 ]; then
  echo "demo: refinement was not applied (exit code 3): demo-out/refined.json holds the" \
    "leveled poses"
elif [ "$refine_status" -ne 0 ]; then
  echo "demo: rigfit refine failed with exit code $refine_status" >&2
  exit "$refine_status"
fi

heading "before refinement: demo-out/init.json against the truth"
rigfit evaluate demo-out/init.json demo-out/gt.json

heading "after refinement: demo-out/refined.json against the truth"
rigfit evaluate demo-out/refined.json demo-out/gt.json
