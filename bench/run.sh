#!/usr/bin/env bash
# The benchmark suite: regenerates every table of docs/benchmarks.md (accuracy, speed and
# memory, real data, micro-benchmarks) and prints them as markdown.
#
# Usage: bench/run.sh [--quick] [--build DIR] [--out DIR] [SECTION...]
#   SECTION  accuracy | families | faces | variants | bounds | oracle | speed | real | micro | rgbd |
#            loops | view3d (default: all but view3d, in docs/benchmarks.md's order)
#   --quick  a smoke run (about a minute on 2 cores; ctest's bench_quick): every program
#            once on small inputs (1 seed, 160x90 rigs, 10-60 frames, one case per method, the
#            bunny's registration left out), also view_bias, which has no table; checks the
#            script and the programs, its numbers are not for the docs
#   --build  Release build directory (default: <repo>/build) with rigfit, rig_accuracy, sequence_rig,
#            bunny_rig (and io_bench, knn_bench, residuals_bench for micro): cmake --build DIR
#            --target rigfit rig_accuracy sequence_rig bunny_rig io_bench knn_bench residuals_bench
#   --out    where results go (default: DIR/bench-results/<date-time>): SECTION.md (markdown,
#            ready to paste) and raw/ (every program's output)
#
# Sections (docs/benchmarks.md says which table each regenerates):
#   accuracy  bench/rig_accuracy over seeds 0..9: joint and pairwise x point_to_plane and gicp
#             on the default rig, noise 0, the --bare rig and the wide start (yaw 3 deg, 10 cm).
#             Runs under nice: accuracy does not depend on the load.
#   families  bench/rig_accuracy --sigma on the four depth families (white, correlated, stereo
#             matching, stereo with one camera's disparity off by 0.1 px): joint point_to_plane,
#             joint surface_bundle (the default) and pairwise; seeds 0..9 x 2 noise draws (stereo
#             0..4), then the default on held-out seeds 10..14. Error, bias share, runs worse
#             than their start, normalised error (error / reported 1-sigma). Niced, 1 thread.
#   faces     the surface bundle's faces by rays (the default) and found in the depth images
#             (icp.surface_faces: image), side by side at one commit on the families' cases:
#             seeds 0..9 x 2 draws (stereo 0..4; miscalibrated x 1) and held-out 10..14 x 1.
#             Niced, 1 thread.
#   variants  bench/rig_accuracy --sigma on variants of the default (seeds 0..4): depth models on
#             miscalibrated cameras, stereo at 320x180, pairwise with the bundle, the bare room,
#             a 3-camera rig. Niced, 1 thread.
#   oracle    bench/rig_accuracy --face-oracle --face-finder: the default against the face oracle
#             (the bundle's estimator told each pixel's true face: analysis/face_oracle.h), with
#             independent pixels and whitened, on white, correlated and stereo rigs; and the same
#             estimator on the image face finder's faces (analysis/face_finder.h), on the true
#             faces with its pixels, and split where it splits them. Niced, 1 thread (minutes).
#   bounds    bench/rig_accuracy --crlb: the Cramer-Rao bounds (docs/uncertainty.md section 9) and
#             error / bound, white noise (seeds 0..9 x 3 draws; point_to_plane and the surface
#             bundle) and correlated noise (the bundle, seeds 0..2, also without the pixels next
#             to another face). Niced, 2 threads (the bounds' 2000 draws; over an hour).
#   speed     whole-process rigfit refine on rigfit simulate captures, wall time and peak RSS
#             (/usr/bin/time) and the stage times of _meta.icp_refined.timings_s (joint, pairwise
#             and, for the stage breakdown and the camera counts, the surface bundle), median of
#             5 runs (stage breakdown, 4 cameras) or 3 runs (2/4/8/16 cameras at 640x360;
#             320x180/640x360/1280x720 with 4 cameras), and one run of 16 cameras at 1280x720.
#             Not niced; the 1-minute load average at the start of each case is recorded.
#   real      bench/sequence_rig (TUM fr1/xyz and 7-Scenes frames as 5-camera rigs, against
#             their ground truth; the joint mode with point_to_plane and surface_bundle) and
#             bench/bunny_rig (the Stanford bunny's 10 scans imported with rigfit import-ply,
#             checked against bun.conf, then registered from perturbed starts).
#   micro     the Google Benchmark programs io_bench, knn_bench and residuals_bench (capture
#             I/O, nearest-neighbour backends and preprocessing, residuals analytic vs
#             autodiff), median of 5 repetitions. Not niced.
#   rgbd      dense RGB-D tracking: rigfit track --evaluate on the 400 7-Scenes frames (default,
#             without keyframes, and the variants of docs/benchmarks.md), on the TUM fr1/xyz
#             subset, on rigfit simulate-sequence sequences (noise-free, Kinect noise and stereo
#             block matching; the stereo one also with --color-tracking off, --max-depth 2.5,
#             --bilateral-range-grows
#             (and --max-angle 60) and by rigfit slam; Kinect noise and the kitchen with
#             --bilateral-range-grows), and
#             bench/rgbd_bench (pyramid, normal equations, both solve paths, tracking at 640x480
#             and 320x240), median of 5 repetitions; rigfit slam --evaluate on the 7-Scenes
#             frames and the TUM fr1/xyz subset with the default halving (to 320x240) and at
#             640x480 (--halve 0), median of 3 runs by frames/s with loading, peak RSS from
#             /usr/bin/time. Not niced.
#   loops     rigfit track and slam on synthetic closed loops (seeds 1..5, 600 frames 320x240;
#             seed 1 at 640x480; seeds 1..5 with stereo depth, seeds 1 and 2 track also with
#             --bilateral-range-grows --max-angle 60 and with --color-tracking off) and the
#             real sequences: loop
#             closure's counts, ATE, RPE and end
#             drift without and with it; then the same loops with a lone-plane stretch (floor
#             only for 0.7 s), depth only and with textured colour: ATE against the loop
#             without it. Not niced (about an hour).
#   view3d    the reports' 3-D view: folder size and time to interactive in headless Chromium
#             (bench/view3d_ready.sh) of refine, compare, fuse and slam reports. Needs chromium;
#             only when named.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="$root/build"
out=""
quick=0
sections=()
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick=1 ;;
    --build) build="$2"; shift ;;
    --out) out="$2"; shift ;;
    accuracy | families | faces | variants | bounds | oracle | speed | real | micro | rgbd | loops | view3d)
      sections+=("$1") ;;
    -h | --help) sed -n '2,/^[^#]/{/^#/p}' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench/run.sh: unknown argument '$1' (try --help)" >&2; exit 2 ;;
  esac
  shift
done
[ ${#sections[@]} -gt 0 ] || sections=(accuracy families faces variants bounds oracle real speed rgbd loops micro)
build="$(cd "$build" && pwd)"
out="${out:-$build/bench-results/$(date +%Y%m%d-%H%M%S)}"
mkdir -p "$out/raw"
out="$(cd "$out" && pwd)"
rigfit="$build/cli/rigfit"
for tool in "$rigfit" "$build/bench/rig_accuracy" "$build/bench/sequence_rig" "$build/bench/bunny_rig" \
  "$build/bench/view_bias"; do
  [ -x "$tool" ] || { echo "bench/run.sh: $tool is missing: build it first" >&2; exit 2; }
done
for tool in /usr/bin/time python3; do
  command -v "$tool" >/dev/null || { echo "bench/run.sh: needs $tool" >&2; exit 2; }
done

load1() { cut -d' ' -f1 /proc/loadavg; }

# The section's markdown file starts with what was run, where and when.
header() {
  local file="$out/$1.md"
  {
    echo "<!-- bench/run.sh $1$([ $quick = 1 ] && echo ' --quick') -->"
    echo "Measured $(date '+%Y-%m-%d %H:%M %Z') at commit \`$(git -C "$root" describe --always --dirty)\`,"
    echo "$(nproc) cores ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')),"
    echo "load average $(cut -d' ' -f1-3 /proc/loadavg) at the start."
    echo
  } >"$file"
  echo "$file"
}

# ---------------------------------------------------------------------------------------------
# accuracy

# Markdown per-seed table of one rig_accuracy output, then its summary row appended to $2.
accuracy_tables() {
  local raw="$1" summary="$2" rig="$3" mode="$4" method="$5" file="$6"
  {
    echo "#### $rig, $mode, $method"
    echo
    echo "| seed | before rot deg | before trans mm | before tilt deg | after rot deg | after trans mm | after tilt deg | worst pair mm | leveling s | preprocessing s | registration s | result |"
    echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
    # Rows "seed | before x3 | after x4 | times x3 | result", the result a free-text message.
    awk -F'|' '/^ *[0-9]+ \|/ {
      n = split($1 " " $2 " " $3 " " $4, f, " ")
      row = "|"; for (i = 1; i <= n; ++i) row = row " " f[i] " |"
      result = substr($0, index($0, $5)); sub(/^ +/, "", result)
      print row " " result " |" }' "$raw"
    echo
  } >>"$file"
  # RMS over the seeds of the per-seed "before" RMS; seeds whose worst pair is under 50 mm.
  awk -F'|' -v rig="$rig" -v mode="$mode" -v method="$method" '
    /^ *[0-9]+ \|/ { split($2, b, " "); split($3, a, " "); r += b[1]^2; t += b[2]^2; s += b[3]^2
                     n++; if (a[4] < 50) ok++ }
    /^summary/ { line = $0 }
    END {
      match(line, /rotation [0-9.]+/); rot = substr(line, RSTART + 9, RLENGTH - 9)
      match(line, /translation [0-9.]+/); tr = substr(line, RSTART + 12, RLENGTH - 12)
      match(line, /worst pair [0-9.]+/); wp = substr(line, RSTART + 11, RLENGTH - 11)
      match(line, /tilt [0-9.]+/); tilt = substr(line, RSTART + 5, RLENGTH - 5)
      match(line, /[0-9]+ runs not/); fail = substr(line, RSTART, RLENGTH - 9)
      printf "| %s | %s | %s | %.3f / %.1f / %.3f | %s | %s | %s | %s | %d of %d | %s |\n",
        rig, mode, method, sqrt(r / n), sqrt(t / n), sqrt(s / n), rot, tr, wp, tilt, ok, n, fail
    }' "$raw" >>"$summary"
}

run_accuracy() {
  local file seeds=10 size=() summary="$out/raw/accuracy-summary.md"
  file="$(header accuracy)"
  : >"$summary"
  local cases=(
    "default rig|joint|point_to_plane|"
    "default rig|joint|gicp|"
    "default rig|pairwise|point_to_plane|"
    "default rig|pairwise|gicp|"
    "default rig|joint|surface_bundle|"
    "noise 0|joint|point_to_plane|--noise 0"
    "noise 0|pairwise|point_to_plane|--noise 0"
    "noise 0|joint|surface_bundle|--noise 0"
    "bare room|joint|point_to_plane|--bare"
    "bare room|pairwise|point_to_plane|--bare"
    "bare room|joint|surface_bundle|--bare"
    "correlated noise (80% over 4 px)|joint|point_to_plane|--noise-corr-px 4 --noise-corr-share 0.8"
    "correlated noise (80% over 4 px)|pairwise|point_to_plane|--noise-corr-px 4 --noise-corr-share 0.8"
    "correlated noise (80% over 4 px)|joint|surface_bundle|--noise-corr-px 4 --noise-corr-share 0.8"
    "wide start (yaw 3 deg, 10 cm)|joint|point_to_plane|--perturb-yaw-deg 3 --perturb-xz-m 0.1"
    "wide start (yaw 3 deg, 10 cm)|pairwise|point_to_plane|--perturb-yaw-deg 3 --perturb-xz-m 0.1"
  )
  if [ $quick = 1 ]; then
    seeds=1
    size=(--width 160 --height 90)
    # One case per method; the surface bundle's with its bound and segmentation diagnostics.
    cases=(
      "default rig|joint|point_to_plane|"
      "default rig|pairwise|gicp|"
      "default rig|joint|surface_bundle|--crlb --segmentation"
    )
    echo "+ view_bias --seeds 1 ${size[*]}" >&2
    nice "$build/bench/view_bias" --seeds 1 "${size[@]}" >"$out/raw/view_bias.txt"
  fi
  local details="$out/raw/accuracy-details.md"
  : >"$details"
  for c in "${cases[@]}"; do
    IFS='|' read -r rig mode method extra <<<"$c"
    local raw="$out/raw/accuracy-${rig%% *}-$mode-$method.txt"
    # shellcheck disable=SC2086 # extra holds several flags
    echo "+ rig_accuracy --mode $mode --method $method --seeds $seeds ${size[*]} $extra" | tee "$raw" >&2
    # shellcheck disable=SC2086
    nice "$build/bench/rig_accuracy" --mode "$mode" --method "$method" --seeds "$seeds" \
      "${size[@]}" $extra >>"$raw"
    accuracy_tables "$raw" "$summary" "$rig" "$mode" "$method" "$details"
  done
  {
    echo "Command per row: \`bench/rig_accuracy --mode M --method X --seeds $seeds ${size[*]}\` plus the"
    echo "rig's flags (\`--noise 0\`, \`--bare\`, \`--perturb-yaw-deg 3 --perturb-xz-m 0.1\`,"
    echo "\`--noise-corr-px 4 --noise-corr-share 0.8\`), seeds 0..$((seeds - 1)),"
    echo "4 cameras$([ $quick = 1 ] && echo ' 160x90' || echo ' 640x360'), default config. Errors are gauge-free (core/evaluate.h); \"start\" is"
    echo "the RMS over the seeds of each seed's RMS before refinement (rotation deg / translation mm /"
    echo "tilt deg); the others are RMS over every pair (tilt: every camera) of every seed."
    echo
    echo "| rig | mode | method | start | RMS rel. rotation deg | RMS rel. translation mm | worst pair mm | RMS tilt deg | seeds with worst pair < 50 mm | runs not successful |"
    echo "|---|---|---|---|---|---|---|---|---|---|"
    cat "$summary"
    echo
    echo "### Per seed"
    echo
    cat "$details"
  } >>"$file"
  echo "load average $(cut -d' ' -f1-3 /proc/loadavg) at the end." >>"$file"
}

# ---------------------------------------------------------------------------------------------
# families

# Runs bench/rig_accuracy niced with ARGS (flags may come as one word each), its command line
# first in RAW and on stderr, then its output and errors in RAW.
accuracy_run() {
  local raw="$1"
  shift
  echo "+ rig_accuracy $*" | tee "$raw" >&2
  # shellcheck disable=SC2048,SC2086 # a case's flags arrive as one word: split them
  nice "$build/bench/rig_accuracy" $* >>"$raw" 2>&1
}

# One markdown row of the four-family table from one rig_accuracy output (--sigma; bias share
# only with more than one noise draw).
family_row() {
  python3 - "$@" <<'PY'
import re, sys
raw, family, method, runs = sys.argv[1:5]
text = open(raw).read()
def num(pattern, group=1):
    m = re.search(pattern, text)
    return m.group(group) if m else "-"
summary = r"RMS relative rotation ([0-9.]+) deg, RMS relative translation ([0-9.]+) mm \(worst pair ([0-9.]+) mm\), RMS tilt ([0-9.]+) deg"
bias = r"share of the mean squared error[^:]*: ([0-9.-]+) rotation, ([0-9.-]+) translation"
worse = r"worse than their start: (\d+) in RMS rotation, (\d+) in RMS translation"
normalised = r"normalised errors[^:]*: RMS ([0-9.]+) rotation, ([0-9.]+) translation"
cells = [family, method, runs] + [num(summary, g) for g in (1, 2, 3, 4)]
cells += ["%s / %s" % (num(bias, 1), num(bias, 2)) if re.search(bias, text) else "-"]
cells += ["%s / %s" % (num(worse, 1), num(worse, 2))]
cells += ["%s / %s" % (num(normalised, 1), num(normalised, 2)) if re.search(normalised, text) else "-"]
if len(sys.argv) > 5:  # the depth models' offsets against the truth
    offsets = r"miscalibrated cameras mean ([0-9.-]+) RMS ([0-9.]+) \((\d+)\), the others mean [0-9.-]+ RMS ([0-9.]+) \((\d+)\); not observable: (\d+)"
    m = re.search(offsets, text)
    cells += ["%s (RMS %s, %s cameras) / %s (%s) / %s" % m.groups() if m else "-"]
print("| " + " | ".join(cells) + " |")
PY
}

run_families() {
  local file size=() table="$out/raw/families-table.md"
  file="$(header families)"
  : >"$table"
  local white="" correlated="--noise-corr-px 4 --noise-corr-share 0.8"
  local stereo="--depth-model stereo --stereo-upsample 2"
  local miscalibrated="$stereo --disparity-offset-px 0.1 --miscalibrated-cameras 1"
  # family|flags|first seed|seeds|draws|mode|method
  local cases=(
    "white|$white|0|10|2|joint|point_to_plane"
    "white|$white|0|10|2|joint|surface_bundle"
    "white|$white|0|10|1|pairwise|point_to_plane"
    "correlated|$correlated|0|10|2|joint|point_to_plane"
    "correlated|$correlated|0|10|2|joint|surface_bundle"
    "correlated|$correlated|0|10|1|pairwise|point_to_plane"
    "stereo|$stereo|0|5|2|joint|point_to_plane"
    "stereo|$stereo|0|5|2|joint|surface_bundle"
    "stereo|$stereo|0|5|1|pairwise|point_to_plane"
    "stereo, camera 1 +0.1 px|$miscalibrated|0|5|1|joint|point_to_plane"
    "stereo, camera 1 +0.1 px|$miscalibrated|0|5|1|joint|surface_bundle"
    "white, held out|$white|10|5|1|joint|surface_bundle"
    "correlated, held out|$correlated|10|5|1|joint|surface_bundle"
    "stereo, held out|$stereo|10|5|1|joint|surface_bundle"
    "stereo, camera 1 +0.1 px, held out|$miscalibrated|10|5|1|joint|surface_bundle"
  )
  if [ $quick = 1 ]; then
    size=(--width 160 --height 90)
    cases=(
      "white|$white|0|1|2|joint|surface_bundle"
      "stereo, camera 1 +0.1 px|$miscalibrated|0|1|1|joint|surface_bundle"
    )
  fi
  local c family flags first seeds draws mode method
  for c in "${cases[@]}"; do
    IFS='|' read -r family flags first seeds draws mode method <<<"$c"
    local raw="$out/raw/families-$(echo "$family $mode $method" | tr -c 'a-zA-Z0-9' '_').txt"
    accuracy_run "$raw" --mode "$mode" --method "$method" --first-seed "$first" --seeds "$seeds" \
      --noise-draws "$draws" --sigma --threads 1 "${size[@]}" "$flags"
    family_row "$raw" "$family" "$mode, $method" \
      "$seeds x $draws (seeds $first..$((first + seeds - 1)))" >>"$table"
  done
  {
    echo "Command per row: \`bench/rig_accuracy --mode M --method X --first-seed F --seeds N"
    echo "--noise-draws D --sigma --threads 1${size[*]:+ ${size[*]}}\` plus the family's flags: white (none),"
    echo "correlated (\`$correlated\`), stereo (\`$stereo\`), stereo"
    echo "miscalibrated (\`$miscalibrated\`). 4 cameras, default config. \"worse\": runs ending worse"
    echo "than their start (rotation / translation). Bias share: the part of the mean squared error"
    echo "every noise draw repeats (two draws or more). Normalised: error / reported 1-sigma, RMS over"
    echo "the cameras (rotation / translation)."
    echo
    echo "| family | method | runs | rotation deg | translation mm | worst pair mm | tilt deg | bias share rot / trans | worse | normalised rot / trans |"
    echo "|---|---|---|---|---|---|---|---|---|---|"
    cat "$table"
    echo
    echo "load average $(cut -d' ' -f1-3 /proc/loadavg) at the end."
  } >>"$file"
}

# The surface bundle's faces: by rays (the default) and found in the depth images, on the
# families' cases; rows as run_families'.
run_faces() {
  local file size=() table="$out/raw/faces-table.md" image="$out/raw/surface-faces-image.yaml"
  file="$(header faces)"
  : >"$table"
  echo "icp: {surface_faces: image}" >"$image"
  local correlated="--noise-corr-px 4 --noise-corr-share 0.8"
  local stereo="--depth-model stereo --stereo-upsample 2"
  local miscalibrated="$stereo --disparity-offset-px 0.1 --miscalibrated-cameras 1"
  # family|flags|first seed|seeds|draws
  local cases=(
    "white||0|10|2" "correlated|$correlated|0|10|2" "stereo|$stereo|0|5|2"
    "stereo, camera 1 +0.1 px|$miscalibrated|0|5|1" "white, held out||10|5|1"
    "correlated, held out|$correlated|10|5|1" "stereo, held out|$stereo|10|5|1"
    "stereo, camera 1 +0.1 px, held out|$miscalibrated|10|5|1"
  )
  if [ $quick = 1 ]; then
    size=(--width 160 --height 90)
    cases=("white||0|1|1")
  fi
  local c family flags first seeds draws faces
  for c in "${cases[@]}"; do
    IFS='|' read -r family flags first seeds draws <<<"$c"
    for faces in rays image; do
      local raw config=()
      raw="$out/raw/faces-$(echo "$family $faces" | tr -c 'a-zA-Z0-9' '_').txt"
      [ $faces = image ] && config=(--config "$image")
      accuracy_run "$raw" --method surface_bundle --first-seed "$first" --seeds "$seeds" \
        --noise-draws "$draws" --sigma --threads 1 "${size[@]}" "${config[@]}" "$flags"
      family_row "$raw" "$family" "$faces" \
        "$seeds x $draws (seeds $first..$((first + seeds - 1)))" >>"$table"
    done
  done
  {
    echo "Command per row: \`bench/rig_accuracy --method surface_bundle --first-seed F --seeds N"
    echo "--noise-draws D --sigma --threads 1${size[*]:+ ${size[*]}}\` plus the family's flags (as in the"
    echo "families table) and, for \"image\", \`--config\` with \`icp: {surface_faces: image}\`. Columns as"
    echo "in the families table."
    echo
    echo "| family | faces | runs | rotation deg | translation mm | worst pair mm | tilt deg | bias share rot / trans | worse | normalised rot / trans |"
    echo "|---|---|---|---|---|---|---|---|---|---|"
    cat "$table"
    echo
    echo "load average $(cut -d' ' -f1-3 /proc/loadavg) at the end."
  } >>"$file"
}

# The variants of the default: depth models, low resolution, the bare room, a small rig,
# pairwise with the bundle; rows as run_families', plus the depth models' offsets.
run_variants() {
  local file size=() table="$out/raw/variants-table.md" seeds=5
  file="$(header variants)"
  : >"$table"
  local offset="$out/raw/depth-offset.yaml" scale="$out/raw/depth-scale-offset.yaml"
  echo "icp: {depth_model: offset}" >"$offset"
  echo "icp: {depth_model: scale_offset}" >"$scale"
  local correlated="--noise-corr-px 4 --noise-corr-share 0.8" stereo="--depth-model stereo --stereo-upsample 2"
  local off="--disparity-offset-px 0.1 --miscalibrated-cameras 1"
  local low="--width 320 --height 180"
  # label|method column|flags[|seeds] (each also gets --sigma --threads 1; seeds default 5)
  local cases=(
    "white|offset|--method surface_bundle --config $offset"
    "white, camera 1 +0.1 px|none|--method surface_bundle $off"
    "white, camera 1 +0.1 px|offset|--method surface_bundle $off --config $offset"
    "white, camera 1 +0.1 px|scale_offset|--method surface_bundle $off --config $scale"
    "white, camera 1 depth x1.01|none|--method surface_bundle --depth-scale 1.01 --miscalibrated-cameras 1"
    "white, camera 1 depth x1.01|scale_offset|--method surface_bundle --depth-scale 1.01 --miscalibrated-cameras 1 --config $scale"
    "stereo|offset|--method surface_bundle $stereo --config $offset"
    "stereo, camera 1 +0.1 px|offset|--method surface_bundle $stereo $off --config $offset"
    "stereo 320x180|joint, surface_bundle|--method surface_bundle $stereo $low"
    "stereo 320x180|joint, point_to_plane|$stereo $low"
    "stereo 320x180|pairwise, point_to_plane|--mode pairwise $stereo $low"
    "stereo 320x180|joint, gicp|--method gicp $stereo $low"
    "stereo 320x180, camera 1 +0.1 px|joint, surface_bundle|--method surface_bundle $stereo $off $low"
    "stereo 320x180, camera 1 +0.1 px|joint, point_to_plane|$stereo $off $low"
    "white|pairwise, surface_bundle|--mode pairwise --method surface_bundle"
    "correlated|pairwise, surface_bundle|--mode pairwise --method surface_bundle $correlated"
    "stereo|pairwise, surface_bundle|--mode pairwise --method surface_bundle $stereo"
    "bare room|joint, point_to_plane|--bare|10"
    "bare room|joint, surface_bundle|--bare --method surface_bundle|10"
    "3 cameras 320x180|joint, point_to_plane|--cameras 3 $low|8"
    "3 cameras 320x180|joint, surface_bundle|--cameras 3 $low --method surface_bundle|8"
  )
  if [ $quick = 1 ]; then
    seeds=1
    size=(--width 160 --height 90)
    cases=("white, camera 1 +0.1 px|offset|--method surface_bundle $off --config $offset")
  fi
  local c label method flags n
  for c in "${cases[@]}"; do
    IFS='|' read -r label method flags n <<<"$c"
    n="${n:-$seeds}"
    [ $quick = 1 ] && n=1
    local raw="$out/raw/variants-$(echo "$label $method" | tr -c 'a-zA-Z0-9' '_').txt"
    accuracy_run "$raw" --seeds "$n" --sigma --threads 1 "${size[@]}" "$flags"
    family_row "$raw" "$label" "$method" "$(sed -n 's/^summary over \([0-9]* [a-z]*\):.*/\1/p' "$raw")" \
      offsets >>"$table"
  done
  {
    echo "Command per row: \`bench/rig_accuracy --seeds N --sigma --threads 1${size[*]:+ ${size[*]}}\` plus the row's"
    echo "flags (raw/variants-*.txt start with them): a depth model is \`--config\` with \`icp:"
    echo "{depth_model: offset}\` or \`scale_offset\` (docs/residuals.md section 11); \"camera 1 +0.1 px\" is"
    echo "\`$off\`, \"depth x1.01\" \`--depth-scale 1.01 --miscalibrated-cameras 1\`; stereo"
    echo "\`$stereo\`; 320x180 \`$low\`. Columns as in the families table; depth"
    echo "model: the error of the offset estimates in px (estimate - truth; a camera not observable keeps"
    echo "0), mean over the miscalibrated cameras (RMS, count) / RMS over the others (count) / cameras"
    echo "not observable."
    echo
    echo "| variant | method | runs | rotation deg | translation mm | worst pair mm | tilt deg | bias share rot / trans | worse | normalised rot / trans | depth model offset error px: miscalibrated mean (RMS, n) / others RMS (n) / not observable |"
    echo "|---|---|---|---|---|---|---|---|---|---|---|"
    cat "$table"
    echo
    echo "load average $(cut -d' ' -f1-3 /proc/loadavg) at the end."
  } >>"$file"
}

# ---------------------------------------------------------------------------------------------
# bounds

# Markdown rows of one rig_accuracy --crlb output: the estimator's error, then each bound with
# the RMS over the runs of error / bound.
bound_rows() {
  python3 - "$@" <<'PY'
import re, sys
raw, label = sys.argv[1:3]
text = open(raw).read()
m = re.search(r"RMS relative rotation ([0-9.]+) deg, RMS relative translation ([0-9.]+) mm.*RMS tilt ([0-9.]+) deg", text)
error = "%s / %s / %s" % m.groups() if m else "-"
names = [(r"^surface-model bound", "surface-model bound"),
         (r"^correlated-noise surface bound", "surface-model bound, correlated noise"),
         (r"^  without the pixels within (\d+) px", "the same without the %s-px ring"),
         (r"^point-to-plane information bound", "point-to-plane information bound"),
         (r"^estimator under shared point noise", "the estimator's own sandwich under shared noise")]
numbers = re.compile(r"RMS ([0-9.]+) deg ([0-9.]+) mm(?: tilt ([0-9.]+) deg)?;.*: ([0-9.]+) rotation, ([0-9.]+) translation")
for line in text.splitlines():
    for pattern, name in names:
        head = re.match(pattern, line)
        found = numbers.search(line)
        if not head or not found:
            continue
        rot, trans, tilt, ratio_r, ratio_t = found.groups()
        print("| %s | %s | %s | %s / %s / %s | %s / %s |" % (
            label, error, name % head.groups() if head.groups() else name, rot, trans,
            tilt or "-", ratio_r, ratio_t))
PY
}

run_bounds() {
  local file size=() table="$out/raw/bounds-table.md"
  file="$(header bounds)"
  : >"$table"
  local correlated="--noise-corr-px 4 --noise-corr-share 0.8"
  # label|flags
  local cases=(
    "white, joint point_to_plane, 10 x 3|--seeds 10 --noise-draws 3"
    "white, joint surface_bundle, 10 x 3|--seeds 10 --noise-draws 3 --method surface_bundle"
    "correlated, joint surface_bundle, 3 x 1|--seeds 3 --method surface_bundle $correlated --bound-boundary-px 1 2"
  )
  if [ $quick = 1 ]; then
    size=(--width 160 --height 90)
    # The correlated-noise bound takes minutes even at 160x90: the white case only.
    cases=("white, joint surface_bundle, 1 x 1|--seeds 1 --method surface_bundle")
  fi
  local c label flags
  for c in "${cases[@]}"; do
    IFS='|' read -r label flags <<<"$c"
    local raw="$out/raw/bounds-$(echo "$label" | tr -c 'a-zA-Z0-9' '_').txt"
    accuracy_run "$raw" --crlb --threads 2 "${size[@]}" "$flags"
    bound_rows "$raw" "$label" >>"$table"
  done
  {
    echo "Command per row: \`bench/rig_accuracy --crlb --threads 2${size[*]:+ ${size[*]}}\` plus the case's flags"
    echo "(\`--seeds 10 --noise-draws 3 [--method surface_bundle]\`; correlated: \`--seeds 3 --method"
    echo "surface_bundle $correlated --bound-boundary-px 1 2\`), 4 cameras, default config;"
    echo "docs/uncertainty.md section 9 defines each bound. Error and bound: RMS over the runs, rotation"
    echo "deg / translation mm / tilt deg; error / bound: RMS over the runs of each run's ratio."
    echo
    echo "| case | error | bound | bound value | error / bound rot / trans |"
    echo "|---|---|---|---|---|"
    cat "$table"
    echo
    echo "load average $(cut -d' ' -f1-3 /proc/loadavg) at the end."
  } >>"$file"
}

# ---------------------------------------------------------------------------------------------
# oracle

# The markdown row of one rig_accuracy --face-oracle --face-finder output: the default's error,
# the oracle's, the face finder's, and the truth split as the finder's, each with independent
# pixels and whitened (RMS rotation deg / translation mm / tilt deg; translation mm alone for
# the finder's decomposition).
oracle_row() {
  python3 - "$@" <<'PY'
import re, sys
raw, label = sys.argv[1:3]
text = open(raw).read()
rms = r"RMS relative rotation ([0-9.]+) deg, RMS relative translation ([0-9.]+) mm.*RMS tilt ([0-9.]+) deg"
def cell(prefix):
    m = re.search(prefix + rms, text)
    return "%s / %s / %s" % m.groups() if m else "-"
def mm(prefix):
    m = re.search(prefix + rms, text)
    return m.group(2) if m else "-"
gated = sum(int(g) for g in re.findall(r"face oracle, independent pixels: .*, (\d+) gated", text))
print("| %s | %s | %s | %s | %d |" % (label, cell(r"summary over \d+ seeds: "),
      cell(r"face oracle, independent pixels: "), cell(r"face oracle, whitened: "), gated))
print("| %s | %s | %s | %s | %s | %s |" % (label, mm(r"face finder, independent pixels: "),
      mm(r"face finder, whitened: "), mm(r"true faces on the finder's pixels, whitened: "),
      mm(r"true faces split as the finder's, independent pixels: "),
      mm(r"true faces split as the finder's, whitened: ")), file=sys.stderr)
PY
}

run_oracle() {
  local file size=() seeds=(10 10 5) table="$out/raw/oracle-table.md"
  local finder="$out/raw/oracle-finder-table.md"
  file="$(header oracle)"
  : >"$table"
  : >"$finder"
  [ $quick = 1 ] && size=(--width 160 --height 90) && seeds=(1 1 1)
  # label|flags
  local cases=(
    "white, seeds 0..$((seeds[0] - 1))|--seeds ${seeds[0]}"
    "correlated, seeds 0..$((seeds[1] - 1))|--seeds ${seeds[1]} --noise-corr-px 4 --noise-corr-share 0.8"
    "stereo, seeds 0..$((seeds[2] - 1))|--seeds ${seeds[2]} --depth-model stereo --stereo-upsample 2"
  )
  local c label flags
  for c in "${cases[@]}"; do
    IFS='|' read -r label flags <<<"$c"
    local raw="$out/raw/oracle-$(echo "$label" | tr -c 'a-zA-Z0-9' '_').txt"
    accuracy_run "$raw" --face-oracle --face-finder --method surface_bundle --threads 1 \
      "${size[@]}" "$flags"
    oracle_row "$raw" "$label" >>"$table" 2>>"$finder"
  done
  {
    echo "Command per row: \`bench/rig_accuracy --face-oracle --face-finder --method surface_bundle --threads 1${size[*]:+ ${size[*]}}\`"
    echo "plus the case's flags (correlated: \`--noise-corr-px 4 --noise-corr-share 0.8\`; stereo:"
    echo "\`--depth-model stereo --stereo-upsample 2\`), 4 cameras, default config, one noise draw."
    echo "Each cell: RMS over the runs, rotation deg / translation mm / tilt deg. Oracle: the true"
    echo "faces, the same start, the reference at its true pose, no gravity prior; whitened: the"
    echo "true correlation (correlated rigs only). Gated: pixels left out, more than 5 sigma_w from"
    echo "their face's depth."
    echo
    echo "| rigs | default (surface bundle) | oracle, independent pixels | oracle, whitened | gated |"
    echo "|---|---|---|---|---|"
    cat "$table"
    echo
    echo "The face finder (analysis/face_finder.h) at the default's result, solved by the oracle's"
    echo "estimator; then the true faces on the finder's pixels, and split where the finder splits"
    echo "them (a face per true face and finder face). RMS translation mm."
    echo
    echo "| rigs | finder, independent | finder, whitened | truth on its pixels, whitened | truth split as its faces, independent | the same, whitened |"
    echo "|---|---|---|---|---|---|"
    cat "$finder"
    echo
    echo "load average $(cut -d' ' -f1-3 /proc/loadavg) at the end."
  } >>"$file"
}

# ---------------------------------------------------------------------------------------------
# speed

# One speed case: `runs` whole-process runs of rigfit refine; appends one row of medians.
speed_case() {
  local capture_dir="$1" mode="$2" runs="$3" table="$4" label="$5"
  local tsv load args=(--mode "$mode" --no-surface-bundle)
  # "surface_bundle": the joint mode with the surface bundle.
  [ "$mode" = surface_bundle ] && args=(--mode joint --surface-bundle)
  tsv="$out/raw/speed-$(basename "$capture_dir")-$mode.tsv"
  load="$(load1)"
  : >"$tsv"
  for ((run = 1; run <= runs; ++run)); do
    local res="$out/raw/time.txt" code=0
    rm -f "$capture_dir/out-$mode.json"
    /usr/bin/time -f "%e %M" -o "$res" "$rigfit" refine --capture "$capture_dir/capture.h5" \
      --extrinsics "$capture_dir/init.json" --out "$capture_dir/out-$mode.json" "${args[@]}" \
      --quiet >>"$out/raw/speed-refine.log" 2>&1 || code=$?
    # /usr/bin/time's last line holds "wall_s maxrss_kb" (earlier lines: a signal or exit note).
    echo "$(tail -n1 "$res") $code $(python3 -c '
import json, sys
t = json.load(open(sys.argv[1]))["_meta"]["icp_refined"].get("timings_s", {})
print(" ".join(str(t.get(k, "nan")) for k in
      ["load", "leveling", "preprocessing", "correspondences", "solve", "registration",
       "pose_graph", "output"]))' "$capture_dir/out-$mode.json" 2>/dev/null || echo "nan nan nan nan nan nan nan nan")" >>"$tsv"
    echo "  $label $mode run $run: $(tail -n1 "$tsv")" >&2
  done
  python3 - "$tsv" "$label" "$mode" "$runs" "$load" >>"$table" <<'EOF'
import statistics, sys
rows = [line.split() for line in open(sys.argv[1]) if line.strip()]
def median(i, scale=1.0, digits=2):
    values = [float(r[i]) * scale for r in rows if r[i] != "nan"]
    return f"{statistics.median(values):.{digits}f}" if values else "-"
codes = ",".join(sorted({r[2] for r in rows}))
cells = [sys.argv[2], sys.argv[3], sys.argv[4], median(0), median(1, 1 / 1024, 0)]
cells += [median(i, digits=3) for i in range(3, 11)]
cells += [codes, sys.argv[5]]
print("| " + " | ".join(cells) + " |")
EOF
}

simulate() {
  local dir="$1"; shift
  [ -f "$dir/capture.h5" ] || "$rigfit" simulate --out "$dir" "$@" >/dev/null
}

speed_table_header() {
  echo "| case | mode | runs | wall s | peak RSS MB | load s | leveling s | preprocessing s | correspondences s | solve s | registration s | pose graph s | output s | exit codes | load avg at start |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
}

run_speed() {
  local file runs=3 breakdown_runs=5 cams=(2 4 8 16) sizes=(320x180 640x360 1280x720) base=640x360
  file="$(header speed)"
  [ $quick = 1 ] && { runs=1; breakdown_runs=1; cams=(4); sizes=(160x90); base=160x90; }
  local data="$out/raw/captures"
  mkdir -p "$data"
  {
    echo "Whole-process \`rigfit refine --capture capture.h5 --extrinsics init.json --out out.json --mode M --quiet\`"
    echo "(default config, 2 threads) under \`/usr/bin/time -f \"%e %M\"\` on \`rigfit simulate --seed 0\` captures"
    echo "(default noise and perturbation). Wall time and peak RSS of the whole process; stage times from"
    echo "\`_meta.icp_refined.timings_s\` (correspondences and solve are the joint mode's part of registration;"
    echo "pose graph is the pairwise mode's; mode surface_bundle is \`--mode joint --surface-bundle\`, the others \`--no-surface-bundle\`)."
    echo "Each cell is the median over the runs. The machine is"
    echo "shared with other engineers' jobs while measuring: the load average column says how busy it was."
    echo
    echo "#### Stage breakdown by cameras and resolution ($runs runs; 4 cameras $base: $breakdown_runs)"
    echo
    speed_table_header
  } >>"$file"
  local c s n mode
  for c in "${cams[@]}"; do
    n=$runs
    [ "$c" = 4 ] && n=$breakdown_runs
    simulate "$data/c$c-$base" --cameras "$c" --width "${base%x*}" --height "${base#*x}"
    for mode in joint pairwise surface_bundle; do
      speed_case "$data/c$c-$base" "$mode" "$n" "$file" "$c cameras $base"
    done
  done
  for s in "${sizes[@]}"; do
    [ "$s" = "$base" ] && continue
    simulate "$data/c4-$s" --cameras 4 --width "${s%x*}" --height "${s#*x}"
    for mode in joint pairwise; do
      speed_case "$data/c4-$s" "$mode" "$runs" "$file" "4 cameras $s"
    done
  done
  if [ $quick = 0 ]; then
    simulate "$data/c16-1280x720" --cameras 16 --width 1280 --height 720
    speed_case "$data/c16-1280x720" joint 1 "$file" "16 cameras 1280x720"
  fi
  { echo; echo "load average $(cut -d' ' -f1-3 /proc/loadavg) at the end."; } >>"$file"
  rm -rf "$data"
}

# ---------------------------------------------------------------------------------------------
# micro

# One Google Benchmark program: median real and CPU time of each benchmark over the
# repetitions, as a markdown table.
micro_table() {
  local name="$1" file="$2"; shift 2
  local json="$out/raw/$name.json"
  echo "+ $name $*" >&2
  "$build/bench/$name" --benchmark_report_aggregates_only=true --benchmark_format=json "$@" \
    >"$json" 2>"$out/raw/$name.log"
  {
    echo "#### \`bench/$name $*\`"
    echo
    echo "| benchmark | real time | CPU time | unit |"
    echo "|---|---|---|---|"
    python3 - "$json" <<'EOF_PY'
import json, sys
for b in json.load(open(sys.argv[1]))["benchmarks"]:
    if b.get("aggregate_name") == "median":
        print(f"| {b['run_name']} | {b['real_time']:.4g} | {b['cpu_time']:.4g} | {b['time_unit']} |")
EOF_PY
    echo
  } >>"$file"
}

run_micro() {
  local file reps=5 min_time=0.2
  file="$(header micro)"
  [ $quick = 1 ] && { reps=2; min_time=0.01; }  # medians need two repetitions
  for tool in io_bench knn_bench residuals_bench; do
    [ -x "$build/bench/$tool" ] || { echo "bench/run.sh: $build/bench/$tool is missing" >&2; exit 2; }
  done
  {
    echo "Google Benchmark programs (Release), median of $reps repetitions. CPU time counts only"
    echo "this process; wall (real) time is inflated when the machine is shared."
    echo
  } >>"$file"
  # --quick: the shortest runs; knn_bench at its smallest size and one tree of the real scan.
  local quick_time=() knn_filter=()
  [ $quick = 1 ] && {
    quick_time=(--benchmark_min_time="$min_time")
    knn_filter=(--benchmark_filter='/5000$|RealBuild/nanoflann|Eigen|Camera')
  }
  micro_table io_bench "$file" --benchmark_repetitions="$reps" "${quick_time[@]}"
  micro_table knn_bench "$file" --benchmark_repetitions="$reps" --benchmark_min_time="$min_time" \
    "${knn_filter[@]}"
  micro_table residuals_bench "$file" --benchmark_repetitions="$reps" "${quick_time[@]}"
  echo "load average $(cut -d' ' -f1-3 /proc/loadavg) at the end." >>"$file"
}

# ---------------------------------------------------------------------------------------------
# real

# --quick: writes a note in place of output $1 and succeeds (`quick_skip FILE || program >FILE`
# runs the program only without --quick).
quick_skip() {
  [ $quick = 1 ] || return 1
  printf '(not run with --quick)\n\n\n' >"$1"
}

run_real() {
  local file seeds=5
  file="$(header real)"
  [ $quick = 1 ] && seeds=1
  # --quick: each program once (sequence_rig on TUM, bunny_rig with point_to_plane).
  local tum="$out/raw/tum.txt" tum_gt="$out/raw/tum-from-mocap.txt"
  echo "+ sequence_rig --seeds $seeds" >&2
  nice "$build/bench/sequence_rig" --seeds "$seeds" >"$tum"
  quick_skip "$tum_gt" ||
    nice "$build/bench/sequence_rig" --seeds 1 --perturb-deg 0 --perturb-m 0 >"$tum_gt"
  local tum_sb="$out/raw/tum-sb.txt"
  : >"$out/raw/tum-sb-warnings.txt"
  quick_skip "$tum_sb" ||
    nice "$build/bench/sequence_rig" --seeds "$seeds" --method surface_bundle >"$tum_sb" \
      2>"$out/raw/tum-sb-warnings.txt"
  local kitchen="$root/../shared/data/sevenscenes_kitchen" kitchen_frames=(0 10 20 30 40)
  echo "+ sequence_rig --dir sevenscenes_kitchen --frames ${kitchen_frames[*]}" >&2
  quick_skip "$out/raw/kitchen.txt" ||
    nice "$build/bench/sequence_rig" --dir "$kitchen" --frames "${kitchen_frames[@]}" \
      --seeds "$seeds" >"$out/raw/kitchen.txt"
  : >"$out/raw/kitchen-sb-warnings.txt"
  quick_skip "$out/raw/kitchen-sb.txt" ||
    nice "$build/bench/sequence_rig" --dir "$kitchen" --frames "${kitchen_frames[@]}" \
      --seeds "$seeds" --method surface_bundle >"$out/raw/kitchen-sb.txt" \
      2>"$out/raw/kitchen-sb-warnings.txt"

  local bunny_dir="$root/../shared/data/stanford_bunny/data" scans=() capture="$out/raw/bunny.h5"
  for ply in "$bunny_dir"/*.ply; do
    local name
    name="$(basename "$ply" .ply)"
    scans+=("$name=$ply")
  done
  "$rigfit" import-ply --force --out "$capture" "${scans[@]}" >"$out/raw/bunny-import.txt"
  echo "+ bunny_rig --check-gt, --seeds $seeds (point_to_plane, gicp)" >&2
  nice "$build/bench/bunny_rig" --capture "$capture" --check-gt >"$out/raw/bunny-check.txt"
  quick_skip "$out/raw/bunny-p2p.txt" ||
    nice "$build/bench/bunny_rig" --capture "$capture" --seeds "$seeds" >"$out/raw/bunny-p2p.txt"
  quick_skip "$out/raw/bunny-from-conf.txt" ||
    nice "$build/bench/bunny_rig" --capture "$capture" --seeds 1 --perturb-deg 0 --perturb-m 0 \
      >"$out/raw/bunny-from-conf.txt"
  [ $quick = 1 ] || nice "$build/bench/bunny_rig" --capture "$capture" --seeds "$seeds" \
    --method gicp >"$out/raw/bunny-gicp.txt"
  [ $quick = 1 ] || nice "$build/bench/bunny_rig" --capture "$capture" --seeds "$seeds" \
    --method surface_bundle >"$out/raw/bunny-sb.txt"
  {
    echo "#### TUM fr1/xyz frames 0, 9, 18, 27, 36 as a rig: \`bench/sequence_rig --seeds $seeds\`"
    echo
    echo "Errors: RMS relative rotation deg / RMS relative translation mm / worst pair mm against"
    echo "the motion capture."
    echo
    cat "$tum"
    echo
    echo "Started at the motion-capture poses (\`--perturb-deg 0 --perturb-m 0 --seeds 1\`):"
    echo
    tail -n +3 "$tum_gt"
    echo
    echo "The joint mode with \`--method surface_bundle\` (pairwise stays point_to_plane);"
    echo "$(grep -c 'too few planes' "$out/raw/tum-sb-warnings.txt" || true) of $((seeds * 4)) free-camera runs kept their joint point-to-plane pose (too few planes):"
    echo
    tail -n +3 "$tum_sb"
    echo
    echo "#### 7-Scenes kitchen frames ${kitchen_frames[*]} as a rig: \`bench/sequence_rig --dir sevenscenes_kitchen --frames ${kitchen_frames[*]} --seeds $seeds\`"
    echo
    echo "Errors against KinectFusion's poses (good to about 1 cm), as above."
    echo
    tail -n +3 "$out/raw/kitchen.txt"
    echo
    echo "With \`--method surface_bundle\`; $(grep -c 'too few planes' "$out/raw/kitchen-sb-warnings.txt" || true) of $((seeds * 4)) free-camera runs kept their joint point-to-plane pose (too few planes):"
    echo
    tail -n +3 "$out/raw/kitchen-sb.txt"
    echo
    echo "#### Stanford bunny, 10 scans: \`rigfit import-ply\` then \`bench/bunny_rig\`"
    echo
    echo '```'
    cat "$out/raw/bunny-import.txt"
    echo '```'
    echo
    echo "bun.conf checked (\`bunny_rig --check-gt\`): each scan against the union of the other nine at"
    echo "the bun.conf poses, under both readings of the quaternion."
    cat "$out/raw/bunny-check.txt"
    echo
    cat "$out/raw/bunny-p2p.txt"
    echo
    echo "Started at the bun.conf poses (\`--perturb-deg 0 --perturb-m 0 --seeds 1\`):"
    echo
    tail -n +3 "$out/raw/bunny-from-conf.txt"
    if [ $quick = 0 ]; then
      echo
      cat "$out/raw/bunny-gicp.txt"
      echo
      cat "$out/raw/bunny-sb.txt"
    fi
    echo
    echo "load average $(cut -d' ' -f1-3 /proc/loadavg) at the end."
  } >>"$file"
}

# ---------------------------------------------------------------------------------------------
# rgbd

# One markdown row of `rigfit track --evaluate` on SEQUENCE with FLAGS (label first).
track_row() {
  local label="$1" sequence="$2"
  shift 2
  local raw
  raw="$out/raw/track-$(echo "$label $*" | tr -c 'a-zA-Z0-9' '_').txt"
  "$rigfit" track "$sequence" --out "$raw.traj" --evaluate --quiet "$@" >"$raw" 2>&1
  python3 - "$raw" "$label" "$*" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
def num(pattern):  # the last match: after the loop closure when it ran
    found = re.findall(pattern, text)
    return found[-1] if found else "-"
print("| %s | `%s` | %s | %s | %s / %s | %s | %s | %s |" % (
    sys.argv[2], sys.argv[3] or "(defaults)", num(r"tracked (\d+) frames"),
    num(r"ATE RMSE ([0-9.]+) mm"), num(r"RPE per frame ([0-9.]+) mm"),
    num(r"mm / ([0-9.]+) deg"), num(r"\(([0-9.]+) mm per metre\)"),
    num(r"mean matched share ([0-9.]+)"), num(r"frames/s with loading, ([0-9.]+) without\)")))
PY
}

# One markdown row of `rigfit slam --evaluate` on SEQUENCE with FLAGS (label first): the
# median run by frames/s of $runs, each under /usr/bin/time, with the load before it.
slam_row() {
  local label="$1" sequence="$2"
  shift 2
  local base raws=() runs=3
  [ $quick = 1 ] && runs=1
  base="$out/raw/slam-$(echo "$label $*" | tr -c 'a-zA-Z0-9' '_')"
  for r in $(seq 1 $runs); do
    echo "load $(load1)" >"$base-$r.txt"
    /usr/bin/time -v "$rigfit" slam "$sequence" --out "$base-$r.traj" --evaluate --quiet "$@" \
      >>"$base-$r.txt" 2>&1
    raws+=("$base-$r.txt")
  done
  python3 - "$label" "$*" "${raws[@]}" <<'PY'
import re, sys
rows = []
for path in sys.argv[3:]:
    text = open(path).read()
    def num(pattern):  # the last match: after the loop closure when it ran
        found = re.findall(pattern, text, re.M)
        return found[-1] if found else "-"
    rows.append((float(num(r"\(([0-9.]+) frames/s with loading")),
                 num(r"frames/s with loading, ([0-9.]+) without\)"), num(r"ATE RMSE ([0-9.]+) mm"),
                 num(r"RPE per frame ([0-9.]+) mm"), num(r"mm / ([0-9.]+) deg"),
                 num(r"^map (\d+) points"), "%.0f" % (int(num(r"Maximum resident set size \(kbytes\): (\d+)")) / 1024),
                 num(r"^load ([0-9.]+)")))
rows.sort()
fps, fps_work, ate, rpe_mm, rpe_deg, size, rss, load = rows[len(rows) // 2]
print("| %s | `%s` | %s | %s / %s | %.1f (%s) | %s | %s | %s | %s |" % (
    sys.argv[1], sys.argv[2] or "(defaults)", ate, rpe_mm, rpe_deg, fps,
    " / ".join("%.1f" % r[0] for r in rows), fps_work, size, rss,
    " / ".join(r[-1] for r in rows)))
PY
}

run_rgbd() {
  local file data="$root/../shared/data" sim="$out/raw/sequences"
  file="$(header rgbd)"
  [ -x "$build/bench/rgbd_bench" ] || { echo "bench/run.sh: build rgbd_bench" >&2; exit 2; }
  local frames=300
  [ $quick = 1 ] && frames=10
  mkdir -p "$sim"
  "$rigfit" simulate-sequence --out "$sim/clean" --frames "$frames" --noise none --no-color \
    --force >"$out/raw/simulate-clean.txt" 2>&1
  "$rigfit" simulate-sequence --out "$sim/kinect" --frames "$frames" --no-color \
    --force >"$out/raw/simulate-kinect.txt" 2>&1
  "$rigfit" simulate-sequence --out "$sim/stereo" --frames "$frames" --noise stereo \
    --force >"$out/raw/simulate-stereo.txt" 2>&1
  {
    echo "#### \`rigfit track SEQUENCE --evaluate [flags]\`"
    echo
    echo "| sequence | flags | frames | ATE RMSE mm | RPE per frame mm / deg | end-point drift mm/m | matched share | frames/s (no loading) |"
    echo "|---|---|---|---|---|---|---|---|"
    local kitchen="$data/sevenscenes_kitchen"
    local max=()
    [ $quick = 1 ] && max=(--max-frames 10)
    track_row "7-Scenes kitchen" "$kitchen" "${max[@]}"
    # --quick: one row per sequence.
    [ $quick = 1 ] || track_row "7-Scenes kitchen" "$kitchen" --no-keyframes
    if [ $quick = 0 ]; then
      track_row "7-Scenes kitchen" "$kitchen" --no-keyframes --no-bilateral --no-depth-weights
      track_row "7-Scenes kitchen" "$kitchen" --no-bilateral
      track_row "7-Scenes kitchen" "$kitchen" --no-depth-weights
      track_row "7-Scenes kitchen" "$kitchen" --huber 0.02
    fi
    track_row "TUM fr1/xyz subset" "$data/tum_fr1_xyz_subset" "${max[@]}"
    [ $quick = 1 ] || track_row "TUM fr1/xyz subset" "$data/tum_fr1_xyz_subset" --no-keyframes
    track_row "simulated, noise-free" "$sim/clean"
    [ $quick = 1 ] || track_row "simulated, noise-free" "$sim/clean" --no-keyframes
    track_row "simulated, Kinect noise" "$sim/kinect"
    [ $quick = 1 ] || track_row "simulated, Kinect noise" "$sim/kinect" --no-keyframes
    track_row "simulated, stereo depth" "$sim/stereo"
    if [ $quick = 0 ]; then
      track_row "simulated, stereo depth" "$sim/stereo" --color-tracking off
      track_row "simulated, stereo depth" "$sim/stereo" --max-depth 2.5
      track_row "simulated, stereo depth" "$sim/stereo" --bilateral-range-grows
      track_row "simulated, stereo depth" "$sim/stereo" --bilateral-range-grows --max-angle 60
      track_row "simulated, Kinect noise" "$sim/kinect" --bilateral-range-grows
      track_row "7-Scenes kitchen" "$kitchen" --bilateral-range-grows
    fi
    echo
    echo "#### \`rigfit slam SEQUENCE --evaluate [flags]\`"
    echo
    echo "| sequence (640x480) | flags | ATE RMSE mm | RPE per frame mm / deg | frames/s with loading, median (all runs) | frames/s without loading | map points at the end | peak RSS MB | load before each run |"
    echo "|---|---|---|---|---|---|---|---|---|"
    slam_row "7-Scenes kitchen" "$kitchen" "${max[@]}"
    [ $quick = 1 ] || slam_row "7-Scenes kitchen" "$kitchen" --halve 0
    [ $quick = 1 ] || slam_row "TUM fr1/xyz subset" "$data/tum_fr1_xyz_subset"
    [ $quick = 1 ] || slam_row "TUM fr1/xyz subset" "$data/tum_fr1_xyz_subset" --halve 0
    if [ $quick = 0 ]; then
      slam_row "simulated, stereo depth" "$sim/stereo"
      slam_row "simulated, stereo depth" "$sim/stereo" --bilateral-range-grows
      slam_row "7-Scenes kitchen" "$kitchen" --bilateral-range-grows
      slam_row "TUM fr1/xyz subset" "$data/tum_fr1_xyz_subset" --bilateral-range-grows
    fi
    echo
    echo "bench/rgbd_bench: 7-Scenes frames 300 -> 301 (320x240: their level 1); tracking from"
    echo "the identity, pyramids built beforehand."
    echo
  } >>"$file"
  local reps=5 quick_time=()
  [ $quick = 1 ] && { reps=2; quick_time=(--benchmark_min_time=0.01); }
  micro_table rgbd_bench "$file" --benchmark_repetitions=$reps "${quick_time[@]}"
  echo "load average $(cut -d' ' -f1-3 /proc/loadavg) at the end." >>"$file"
}

# ---------------------------------------------------------------------------------------------
# loops

# One run of `rigfit track|slam SEQUENCE --evaluate` under /usr/bin/time; its output in $1.
loop_run() {
  local raw="$1"
  shift
  echo "+ rigfit $*" | tee "$raw" >&2
  /usr/bin/time -f "wall %e s" "$rigfit" "$@" --out "$raw.traj" --evaluate --quiet >>"$raw" 2>&1
}

# The markdown row of one loop_run output: counts, ATE, RPE and end drift without and with the
# loop closure, wall time (closure time).
loop_row() {
  python3 - "$@" <<'PY'
import re, sys
raw, label, run = sys.argv[1:4]
text = open(raw).read()
def num(pattern, unclosed=False):
    lines = [l for l in text.splitlines() if l.startswith("without loop closure: ") == unclosed]
    found = re.findall(pattern, "\n".join(lines))
    return found[-1] if found else None
counts = num(r"loop closure: (\d+) keyframes, (\d+) candidate\(s\), (\d+) loop\(s\) accepted, (\d+) rejected")
ate = r"ATE RMSE ([0-9.]+) mm"
rpe = r"RPE per frame ([0-9.]+) mm"
drift = r"closed loop: end drift ([0-9.]+) mm / ([0-9.]+) deg"
closed = num(ate, True) is not None  # the unclosed lines exist only when the closure applied
def pair(pattern):
    now = num(pattern)
    before = num(pattern, True) if closed else now
    if now is None:
        return "-"
    if isinstance(now, tuple):
        return "%s / %s -> **%s / %s**" % (before + now)
    return "%s / **%s**" % (before, now)
print("| %s | %s | %s | %s | %s | %s | %s (%s) |" % (
    label, run, " / ".join(counts) if counts else "-", pair(ate), pair(rpe), pair(drift),
    num(r"wall ([0-9.]+) s"), num(r"loop closure: .*\(([0-9.]+) s\)")))
PY
}

# The markdown row of the lone-plane guard: ATE without the stretch, with it (depth only, then
# textured colour), and each run's counts.
lone_row() {
  python3 - "$@" <<'PY'
import re, sys
without, lone, coloured, seed, run = sys.argv[1:6]
def ate(path):
    lines = [l for l in open(path) if not l.startswith("without loop closure: ")]
    found = re.findall(r"ATE RMSE ([0-9.]+) mm", "".join(lines))
    return float(found[-1]) if found else float("nan")
def counts(path):
    guard = re.findall(r"degenerate views: (\d+) frame\(s\) with weak directions, (\d+) of "
                       r"them aligned by colour, (\d+) relocalised", open(path).read())
    return " / ".join(guard[-1]) if guard else "-"
a, b, c = ate(without), ate(lone), ate(coloured)
print("| %s | %s | %.2f | %.2f (%.1fx) | **%.2f (%.1fx)** | %s | %s |" % (
    seed, run, a, b, b / a, c, c / a, counts(lone), counts(coloured)))
PY
}

run_loops() {
  local file sim="$out/raw/loops" data="$root/../shared/data" seeds=(1 2 3 4 5) frames=600
  local size=(--width 320 --height 240) intrinsics=(--intrinsics 262.5,262.5,159.5,119.5)
  local lone=(--lone-plane floor --lone-plane-start 5.4 --lone-plane-seconds 0.7)
  file="$(header loops)"
  if [ $quick = 1 ]; then
    # A smoke run: 60 frames are too few for the 9 m loop to be tracked (numbers meaningless).
    seeds=(2) frames=60 size=(--width 160 --height 120)
    intrinsics=(--intrinsics 131.25,131.25,79.5,59.5)
    lone=(--lone-plane floor --lone-plane-start 1 --lone-plane-seconds 0.3)
  fi
  mkdir -p "$sim"
  local loops="$out/raw/loops-table.md" guard="$out/raw/lone-table.md" s run
  : >"$loops"
  : >"$guard"
  for s in "${seeds[@]}"; do
    local common=(--frames "$frames" --closed-loop --seed "$s" "${size[@]}" --no-color --force)
    "$rigfit" simulate-sequence --out "$sim/loop$s" "${common[@]}" >/dev/null
    "$rigfit" simulate-sequence --out "$sim/lone$s" "${common[@]}" "${lone[@]}" >/dev/null
    "$rigfit" simulate-sequence --out "$sim/lonec$s" --frames "$frames" --closed-loop --seed "$s" \
      "${size[@]}" --force "${lone[@]}" >/dev/null
    for run in track slam; do
      loop_run "$out/raw/loops-$run-loop$s.txt" "$run" "$sim/loop$s" "${intrinsics[@]}"
      loop_run "$out/raw/loops-$run-lone$s.txt" "$run" "$sim/lone$s" "${intrinsics[@]}"
      loop_run "$out/raw/loops-$run-lonec$s.txt" "$run" "$sim/lonec$s" "${intrinsics[@]}"
      loop_row "$out/raw/loops-$run-loop$s.txt" "loop seed $s, ${size[1]}x${size[3]}" "$run" >>"$loops"
      lone_row "$out/raw/loops-$run-loop$s.txt" "$out/raw/loops-$run-lone$s.txt" \
        "$out/raw/loops-$run-lonec$s.txt" "$s" "$run" >>"$guard"
    done
  done
  if [ $quick = 0 ]; then
    "$rigfit" simulate-sequence --out "$sim/loop1-640" --frames 600 --closed-loop --seed 1 \
      --no-color --force >/dev/null
    loop_run "$out/raw/loops-track-640.txt" track "$sim/loop1-640"
    loop_row "$out/raw/loops-track-640.txt" "loop seed 1, 640x480" track >>"$loops"
    loop_run "$out/raw/loops-slam-640.txt" slam "$sim/loop1-640"
    loop_row "$out/raw/loops-slam-640.txt" "loop seed 1, 640x480" "slam (halved)" >>"$loops"
    for s in 1 2 3 4 5; do  # stereo depth (with its colour), as a hand-held ZED gives it
      "$rigfit" simulate-sequence --out "$sim/stereo$s" --frames "$frames" --closed-loop \
        --seed "$s" "${size[@]}" --noise stereo --force >/dev/null
      for run in track slam; do
        loop_run "$out/raw/loops-$run-stereo$s.txt" "$run" "$sim/stereo$s" "${intrinsics[@]}"
        loop_row "$out/raw/loops-$run-stereo$s.txt" "stereo loop seed $s, 320x240" "$run" >>"$loops"
      done
      ((s <= 2)) || continue  # the variants on the first two
      local grows=(--bilateral-range-grows --max-angle 60)  # docs/rgbd.md: for stereo depth
      loop_run "$out/raw/loops-grows-stereo$s.txt" track "$sim/stereo$s" "${intrinsics[@]}" \
        "${grows[@]}"
      loop_row "$out/raw/loops-grows-stereo$s.txt" "stereo loop seed $s, 320x240" \
        "track ${grows[*]}" >>"$loops"
      loop_run "$out/raw/loops-nocolor-stereo$s.txt" track "$sim/stereo$s" "${intrinsics[@]}" \
        --color-tracking off
      loop_row "$out/raw/loops-nocolor-stereo$s.txt" "stereo loop seed $s, 320x240" \
        "track --color-tracking off" >>"$loops"
    done
    for run in track slam; do
      loop_run "$out/raw/loops-$run-kitchen.txt" "$run" "$data/sevenscenes_kitchen"
      loop_row "$out/raw/loops-$run-kitchen.txt" "7-Scenes kitchen 200-599" "$run" >>"$loops"
      loop_run "$out/raw/loops-$run-tum.txt" "$run" "$data/tum_fr1_xyz_subset"
      loop_row "$out/raw/loops-$run-tum.txt" "TUM fr1/xyz subset" "$run" >>"$loops"
    done
  fi
  {
    echo "Synthetic loops: \`rigfit simulate-sequence --out loopS --frames $frames --closed-loop --seed S"
    echo "${size[*]} --no-color\`, then \`rigfit track|slam loopS --out t.txt --evaluate --quiet"
    echo "${intrinsics[*]}\` (640x480: no size, no intrinsics; stereo: \`--noise stereo\` with colour instead"
    echo "of \`--no-color\`); real data: \`rigfit track|slam DATA"
    echo "--out t.txt --evaluate --quiet\`. Counts: keyframes / loop candidates / accepted / rejected after"
    echo "the solve. Each cell: without loop closure (the summary's \`without loop closure:\` lines) /"
    echo "**with** (the default). Wall time of the whole run under \`/usr/bin/time\` (closure s)."
    echo
    echo "| sequence | run | counts | ATE mm | RPE per frame mm | end drift mm / deg | run s (closure s) |"
    echo "|---|---|---|---|---|---|---|"
    cat "$loops"
    echo
    echo "Lone-plane stretches: the same sequences with \`${lone[*]}\` (the camera sees only the"
    echo "floor for that long), depth only (\`--no-color\`) and with the simulator's textured colour"
    echo "(no \`--no-color\`), the same \`track|slam\` command; ATE mm (x the sequence without the"
    echo "stretch); weak-direction frames / aligned by colour / relocalised: the summary's"
    echo "\`degenerate views:\` counts."
    echo
    echo "| seed | run | without the stretch | with it, depth only (ratio) | with it, colour (ratio) | counts, depth only | counts, colour |"
    echo "|---|---|---|---|---|---|---|"
    cat "$guard"
    echo
    echo "load average $(cut -d' ' -f1-3 /proc/loadavg) at the end."
  } >>"$file"
}

# ---------------------------------------------------------------------------------------------
# view3d

# One row: a report folder's size and its 3-D view's time to interactive (bench/view3d_ready.sh).
view3d_row() {
  local label="$1" command="$2" dir="$3" runs="$4" hash="${5:-}" ready="$out/raw/view3d-ready.txt"
  bash "$root/bench/view3d_ready.sh" "$dir" "$runs" "$hash" >"$ready"
  echo "| $label | \`$command\` | $(du -sb "$dir" | awk '{printf "%.1f", $1 / 1e6}') |" \
    "$(sed -n 's/^median (ms): //p' "$ready") ms ($(sed -n 's/^runs (ms): //p' "$ready" | tr ' ' '/')) |" \
    "$(sed -n 's/^load average: //p' "$ready") |"
}

# Not in the default list: needs Debian's chromium (headless, SwiftShader WebGL).
run_view3d() {
  local file sim="$out/raw/view3d" runs=5 slam=(--halve 0)
  command -v chromium >/dev/null || { echo "bench/run.sh: view3d needs chromium" >&2; exit 2; }
  file="$(header view3d)"
  [ $quick = 1 ] && { runs=1; slam=(--max-frames 10); }
  mkdir -p "$sim"
  "$rigfit" simulate --out "$sim/rig" --seed 0 --force >/dev/null
  local rig=(--capture "$sim/rig/capture.h5" --extrinsics "$sim/rig/init.json")
  "$rigfit" refine "${rig[@]}" --out "$sim/rig/refined.json" --report "$sim/refine" --quiet \
    >/dev/null 2>&1
  "$rigfit" compare "${rig[@]}" --gt "$sim/rig/gt.json" --report "$sim/compare" -q >/dev/null 2>&1
  "$rigfit" fuse --capture "$sim/rig/capture.h5" --extrinsics "$sim/rig/gt.json" \
    --map "$sim/map.ply" --force --report "$sim/fuse" >/dev/null 2>&1
  "$rigfit" slam "$root/../shared/data/sevenscenes_kitchen" --out "$sim/kitchen.txt" \
    --report "$sim/slam" --quiet "${slam[@]}" >/dev/null 2>&1
  {
    echo "Report folders of \`rigfit simulate --out rig --seed 0\` (4 cameras 640x360) and of the 7-Scenes"
    echo "kitchen (400 frames 640x480). Size: \`du -sb\`; time to interactive: \`bench/view3d_ready.sh DIR"
    echo "$runs [HASH]\` (headless Chromium, SwiftShader WebGL, 1200x800): from navigation to the first frame"
    echo "with every switched-on layer loaded, median (runs)."
    echo
    echo "| report | command | folder MB | time to interactive | load average |"
    echo "|---|---|---|---|---|"
    view3d_row "rig, refine" "rigfit refine ... --report DIR" "$sim/refine" "$runs"
    view3d_row "rig, refine, whole views on" "rigfit refine ... --report DIR; #layers=band,whole&color=rgb" \
      "$sim/refine" "$runs" '#layers=band,whole&color=rgb'
    view3d_row "rig, compare" "rigfit compare ... --gt rig/gt.json --report DIR" "$sim/compare" "$runs"
    view3d_row "rig, fuse (true poses)" "rigfit fuse ... --report DIR" "$sim/fuse" "$runs"
    view3d_row "7-Scenes kitchen, slam" "rigfit slam DATA/sevenscenes_kitchen --report DIR ${slam[*]}" \
      "$sim/slam" "$runs"
    echo
    echo "load average $(cut -d' ' -f1-3 /proc/loadavg) at the end."
  } >>"$file"
}

for section in "${sections[@]}"; do
  echo "== $section ($(date '+%H:%M:%S'))" >&2
  "run_$section"
  echo "== $section done ($(date '+%H:%M:%S')): $out/$section.md" >&2
done
