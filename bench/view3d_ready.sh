#!/usr/bin/env bash
# Time to interactive of a report's 3-D view in headless Chromium (WebGL by SwiftShader):
# opens REPORT_DIR/view3d.html RUNS times (default 5) and prints the page's data-ready-ms (ms
# from navigation until the first frame is drawn with every switched-on layer loaded) per run
# and their median. Usage: bench/view3d_ready.sh REPORT_DIR [RUNS] [HASH, e.g. '#layers=band,whole']
set -euo pipefail
dir="$(cd "$1" && pwd)"
runs="${2:-5}"
hash="${3:-}"
profile="$(mktemp -d)"
trap 'rm -rf "$profile"' EXIT
times=()
for ((i = 0; i < runs; ++i)); do
  ms=$(timeout 60 chromium --headless --no-sandbox --no-first-run --use-angle=swiftshader \
         --enable-unsafe-swiftshader --user-data-dir="$profile" --window-size=1200,800 \
         --dump-dom "file://$dir/view3d.html$hash" 2>/dev/null |
       grep -o 'data-ready-ms="[0-9]*"' | grep -o '[0-9]*')
  times+=("$ms")
done
echo "runs (ms): ${times[*]}"
echo "median (ms): $(printf '%s\n' "${times[@]}" | sort -n | sed -n "$(((runs + 1) / 2))p")"
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
