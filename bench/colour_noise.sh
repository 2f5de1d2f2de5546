#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Colour noise of nebscatter's field as a frame shows it: the README example (nebgen's PRESET,
# reflection, at RES^3, 128), lit by nebillum, its field computed twice with different seeds
# (nebscatter --seed 1 and 2, the default packets), each rendered at IMAGE (512x512) from
# nebrender's default view; then bench/exr_compare --chromaticity between the two frames: the
# RMS difference of r = R/(R+G+B) and b = B/(R+G+B) over the faint cloud (0.3-3 % of the
# 99.9th percentile of R+G+B) and over the bright cloud. Each FILTERS entry (nebscatter
# options; "none" for none) is measured in turn, with its nebscatter CPU time and field size.
# With REFERENCE=1 also the flux of each frame against a field of 4x the packets (seed 3,
# unfiltered): the filter's bias, per channel (exr_compare's flux_error and block RMS).
#
#   bench/colour_noise.sh                           # none and --denoise 1
#   RES=256 FILTERS="none --denoise=1 --denoise=2" bench/colour_noise.sh
# Environment: BIN (build/tools), COMPARE (build/bench/exr_compare), PRESET (reflection),
#   RES (128), IMAGE (512x512), PACKETS (nebscatter's default), FILTERS, REFERENCE, KEEP=1.
set -euo pipefail
SCRIPT=colour_noise.sh
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
source "$here/common.sh"
BIN=${BIN:-$root/build/tools}
COMPARE=${COMPARE:-$root/build/bench/exr_compare}
PRESET=${PRESET:-reflection}
RES=${RES:-128}
IMAGE=${IMAGE:-512x512}
PACKETS=${PACKETS:-}
FILTERS=${FILTERS:-"none --denoise=1"}
REFERENCE=${REFERENCE:-0}
bench_require "$BIN/nebgen" "$BIN/nebillum" "$BIN/nebscatter" "$BIN/nebrender" "$COMPARE"
bench_tmpdir

packets=()
[[ -n $PACKETS ]] && packets=(--packets "$PACKETS")
timed gen "$BIN/nebgen" --preset "$PRESET" --res "$RES" -o nebula.vdb
timed lit "$BIN/nebillum" -i nebula.vdb -o lit.vdb
echo "# colour noise: $PRESET at ${RES}^3, ${IMAGE}, packets ${PACKETS:-default}; load $(cut -d' ' -f1-3 /proc/loadavg)"
if [[ $REFERENCE == 1 ]]; then
    n=${PACKETS:-1000000}
    timed ref_scatter "$BIN/nebscatter" -i lit.vdb --seed 3 --packets $((4 * n)) -o ref.vdb
    timed ref_render "$BIN/nebrender" -i ref.vdb --res "$IMAGE" --no-png -o ref.exr
fi
for filter in $FILTERS; do
    opts=()
    [[ $filter != none ]] && opts=("$filter")
    for seed in 1 2; do
        timed "scatter$seed" "$BIN/nebscatter" -v -i lit.vdb --seed $seed "${packets[@]}" \
            "${opts[@]}" -o "s$seed.vdb"
        timed "render$seed" "$BIN/nebrender" -i "s$seed.vdb" --res "$IMAGE" --no-png -o "f$seed.exr"
    done
    noise=$(grep -o 'noise of J [0-9.e+-]* %' scatter1.log | head -1)
    after=$(grep -o 'per cell (unweighted mean) [0-9.e+-]* % before, about [0-9.e+-]* % after' \
        scatter1.log | head -1 || true)
    echo "## $filter: nebscatter $(cpu scatter1) s CPU, field $(du -m s1.vdb | cut -f1) MB, $noise${after:+; the filter: noise $after}"
    "$COMPARE" --chromaticity f1.exr f2.exr
    if [[ $REFERENCE == 1 ]]; then
        echo "flux and 8x8-block RMS against 4x the packets (seed 3):"
        "$COMPARE" ref.exr f1.exr --block 8 --threshold 0.01
    fi
done
