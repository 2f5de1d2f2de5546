#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# What the exact star depth (DESIGN §3.3, nebrender's default) costs and what
# --interpolated-tau gives up, on presets at 128^3 rendered at 512x512 with each preset's
# default view: the CPU seconds of both frames, their ratio, and the interpolated frame's
# error against the exact one: total flux per channel, and per 8x8 block the RMS and the
# largest relative error over the blocks at least 1e-3 of the 99th-percentile block
# (build/bench/exr_compare --block 8 --threshold 0.001 --percentile 99 --max).
#
#   bench/star_depth.sh [BUILD] [PRESET...]     (default: build; reflection globule bipolar)
#
# About 1 CPU-minute per preset (bipolar's exact frame is the longest: its star sits in the
# dust). Each frame runs once; the machine's load is printed first.
set -euo pipefail

BUILD=${1:-build}
shift || true
PRESETS=("$@")
((${#PRESETS[@]})) || PRESETS=(reflection globule bipolar)
SCRIPT=star_depth
source "$(dirname "$0")/common.sh"
TOOLS=$(cd "$BUILD/tools" && pwd)
COMPARE=$(cd "$BUILD/bench" && pwd)/exr_compare
bench_require "$TOOLS/nebgen" "$TOOLS/nebillum" "$TOOLS/nebrender" "$COMPARE" "$TIME"
bench_tmpdir

echo "machine: $(nproc) cores; load average $(cut -d' ' -f1-3 /proc/loadavg)"
for p in "${PRESETS[@]}"; do
    timed "gen-$p" "$TOOLS/nebgen" --preset "$p" --res 128 -o "$p.vdb"
    timed "illum-$p" "$TOOLS/nebillum" -i "$p.vdb" -o "$p-lit.vdb"
    timed "exact-$p" "$TOOLS/nebrender" -i "$p-lit.vdb" --res 512x512 --no-png -o "$p-exact.exr"
    timed "interp-$p" "$TOOLS/nebrender" -i "$p-lit.vdb" --res 512x512 --no-png \
        --interpolated-tau -o "$p-interp.exr"
    e=$(cpu "exact-$p") i=$(cpu "interp-$p")
    echo "== $p: exact $e s CPU, interpolated $i s CPU ($(awk -v e="$e" -v i="$i" \
        'BEGIN { printf "%.1fx", e / i }'))"
    "$COMPARE" "$p-exact.exr" "$p-interp.exr" --block 8 --threshold 0.001 --percentile 99 \
        --max | sed -n '1,5p'
done
