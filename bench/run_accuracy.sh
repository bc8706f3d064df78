#!/usr/bin/env bash
# Accuracy and solver time of `rigfit refine` on simulated rigs (docs/benchmarks.md,
# "Refinement accuracy"): modes x methods over seeds 0..9 of the default rig, plus the
# noise-free rig. Usage: bench/run_accuracy.sh [BUILD_DIR] [OUT_DIR]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-$root/build}"
out="${2:-$root/build/bench-results}"
mkdir -p "$out"
bench="$build/bench/rig_accuracy"
for mode in pairwise joint; do
  for method in point_to_plane gicp; do
    "$bench" --mode "$mode" --method "$method" --seeds 10 | tee "$out/${mode}_${method}.txt"
  done
  "$bench" --mode "$mode" --seeds 10 --noise 0 | tee "$out/${mode}_noise0.txt"
done
