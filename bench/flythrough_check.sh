#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Every preset's fly-through as a producer gets it: `make -f Makefile.data flythrough`'s frames
# (the preset at RES^3, 128, with its own path examples/flythrough/<preset>.json, FLY_FRAMES
# 121 frames at FLY_RES, 320x180) toned by nebtone as the Makefile tones them, then
# bench/flythrough_stats.py on the PNGs: the largest jump of a frame's mean display luminance
# from its neighbour and the largest black fraction (pixels whose channels are all <= 8 of
# 255). Targets (issue 47): jump <= 10 %, black <= 80 %. Also the wall time of each preset's
# pipeline and frames.
#
#   bench/flythrough_check.sh                       # all seven presets
#   PRESETS="reflection hii" FLY_RES=160x90 bench/flythrough_check.sh
# Environment: PRESETS, RES (128), FLY_RES (320x180), JOBS (2), MAKE_FLAGS (more make
#   variables, e.g. SCATTER_FLAGS=--packets=200000), KEEP=1.
set -euo pipefail
SCRIPT=flythrough_check.sh
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
source "$here/common.sh"
PRESETS=${PRESETS:-"reflection external pillars bubble hii globule bipolar"}
RES=${RES:-128}
FLY_RES=${FLY_RES:-320x180}
JOBS=${JOBS:-2}
MAKE_FLAGS=${MAKE_FLAGS:-}
bench_require "$root/build/tools/nebrender" "$root/build/tools/nebtone"
bench_tmpdir
echo "# fly-throughs at ${RES}^3, ${FLY_RES}; load $(cut -d' ' -f1-3 /proc/loadavg)"
for p in $PRESETS; do
    start=$(date +%s)
    # shellcheck disable=SC2086 # MAKE_FLAGS: words on purpose
    if ! make -C "$root" -f Makefile.data -j "$JOBS" --no-print-directory PRESET="$p" RES="$RES" \
        OUT="$TMP/$p" FLY_RES="$FLY_RES" $MAKE_FLAGS "$TMP/$p/flythrough/.toned" >"$TMP/$p.log" 2>&1; then
        echo "$SCRIPT: error: the $p fly-through failed:" >&2
        tail -20 "$TMP/$p.log" >&2
        exit 1
    fi
    echo "$p ($(( $(date +%s) - start )) s): $("$here/flythrough_stats.py" "$TMP/$p/flythrough/f.*.png")"
done
