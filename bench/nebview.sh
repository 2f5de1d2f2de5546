#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# nebview's figures on an input (default the example, out/scattered.vdb):
#  1. the server side (bench/nebview_frames, built with the benchmarks): each stage's render,
#     composition, tone and JPEG for a camera orbiting 3 degrees a frame, median of 12
#     (final: of 3), with nebview's peak memory for the scene (/usr/bin/time -v);
#  2. the browser side (tests/view/test_browser.py in headless Chromium on the same cores):
#     page load, latency from mouse input to the frame drawn (median), frames per second while
#     orbiting, time to the first final frame; its screenshot is left in WORK/screenshot.png.
# Targets (docs/tools/nebview.md): latency <= 100 ms, >= 10 fps at 256x256 while orbiting,
# full-resolution refinement within 2 s, page load < 1 s.
#
#   bench/nebview.sh [BUILD] [INPUT] [WORK]   (defaults: build, out/scattered.vdb, a temp dir)
set -euo pipefail
build=${1:-build}
input=${2:-out/scattered.vdb}
work=${3:-$(mktemp -d)}
tools=$(cd "$build/tools" && pwd)
[[ -x $build/bench/nebview_frames ]] || { echo "no $build/bench/nebview_frames: make -C $build nebview_frames" >&2; exit 1; }
[[ -f $input ]] || { echo "no $input: make -f Makefile.data first" >&2; exit 1; }
mkdir -p "$work"
echo "nebview on $input, $(nproc) cores (load before: $(cut -d' ' -f1-3 /proc/loadavg))"
echo "== server: frames for an orbiting camera"
/usr/bin/time -v "$build/bench/nebview_frames" "$input" 12 512x512 2> "$work/time.txt"
awk -F': ' '/Maximum resident/ {printf "peak memory %.0f MiB\n", $2 / 1024}' "$work/time.txt"
echo "== browser: headless Chromium (tests/view/test_browser.py)"
python=python3
[[ -x /usr/bin/python3 ]] && python=/usr/bin/python3
"$python" "$(dirname "$0")/../tests/view/test_browser.py" "$tools/nebview" "$tools/nebrender" \
    "$input" "$work/browser" 2>&1 |
    grep -E "page load|first final|final frame:|latency median|fps while|TIMING|drag:|passed|FAIL"
echo "screenshot: $work/browser/screenshot.png"
