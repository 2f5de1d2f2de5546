#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Spectral rendering benchmarks (DESIGN §7):
#  1. RGB vs spectral render time on the README's example nebula (nebgen --spectral, 128^3,
#     512^2): CPU time of each nebrender process.
#  2. Piecewise-linear spectra vs fixed bands at equal colour accuracy on a Doppler scene (a
#     rotating emission shell, [O III] + H-alpha, velocities exaggerated 300x, 160x160, star
#     sprites off so that the nebula sets the white point): every image is
#     compared with a 4000-band reference by CIEDE2000 (bench/colour_compare: white = the
#     reference's 99.5th-percentile luminance); the table lists CPU time, mean, 99th percentile
#     and largest Delta E 2000, and the rays' piece counts.
#
#     bench/spectral.sh [BUILD_DIR]     (default build; about 2 minutes on 2 cores)
set -euo pipefail
SCRIPT=spectral.sh
HERE=$(cd "$(dirname "$0")" && pwd)
BUILD=$(cd "${1:-$HERE/../build}" && pwd)
source "$HERE/common.sh"
T=$BUILD/tools
bench_require "$T/nebgen" "$T/nebillum" "$T/nebrender" "$BUILD/bench/colour_compare"
bench_tmpdir

cpu() {  # CPU seconds (user + system) of a timed run
    awk -F': ' '/User time/ {u=$2} /System time/ {s=$2} END {printf "%.2f", u + s}' "$1.time"
}
rtime() {  # the render's own wall time (nebrender -v), without reading and building the scene
    sed -n 's/.*render \([0-9.]*\) s,.*/\1/p' "$1.log" | head -1
}

echo "== 1. the example nebula (128^3, 512x512): RGB vs spectral"
timed gen "$T/nebgen" --spectral -o ex.vdb
timed illum "$T/nebillum" -i ex.vdb -o ex-lit.vdb
timed rgb "$T/nebrender" -i ex-lit.vdb -o rgb.exr -v
timed spec "$T/nebrender" -i ex-lit.vdb --spectral -o spec.exr -v
timed bands40 "$T/nebrender" -i ex-lit.vdb --bands 40 -o bands40.exr -v
printf "%-28s %8s\n" mode "CPU [s]"
printf "%-28s %8s\n" "RGB" "$(cpu rgb)"
printf "%-28s %8s\n" "spectral, piecewise-linear" "$(cpu spec)"
printf "%-28s %8s\n" "spectral, 40 fixed bands" "$(cpu bands40)"
grep -h "ns wall per sample" rgb.log spec.log bands40.log | sed 's/^/  /'
echo "  spectral / RGB CPU time: $(awk -v a="$(cpu spec)" -v b="$(cpu rgb)" 'BEGIN {printf "%.2f", a / b}')"

echo
echo "== 2. Doppler scene: piecewise-linear vs fixed bands against a 4000-band reference"
timed sgen "$T/nebgen" --res 64 --spectral --rotation 50 --emission-shape shell --emission 2 \
    --density 100 --lines '[O III]5007:1,[O III]4959:0.33,H-alpha:0.5' -o shell.vdb
timed sillum "$T/nebillum" -i shell.vdb -o shell-lit.vdb
VIEW=(-i shell-lit.vdb --res 160x160 --eye 0,0,-19 --exaggerate-velocity 300 --no-stars --no-png -v)
timed ref "$T/nebrender" "${VIEW[@]}" --bands 4000 -o ref.exr
timed pl "$T/nebrender" "${VIEW[@]}" --spectral -o pl.exr -v
timed plcount "$T/nebrender" "${VIEW[@]}" --spectral --count-pieces --merge-tolerance 1e-3 -o plc.exr -v
BANDS="10 20 40 80 160 200 250 320 400 500 640 1280 2560"
for n in $BANDS; do
    timed "b$n" "$T/nebrender" "${VIEW[@]}" --bands "$n" -o "b$n.exr"
done
"$BUILD/bench/colour_compare" ref.exr pl.exr $(for n in $BANDS; do echo "b$n.exr"; done) > de.txt
head -1 de.txt
printf "%-18s %8s %10s %8s %8s %8s\n" mode "CPU [s]" "render [s]" "mean dE" "p99 dE" "max dE"
row() {  # row LABEL TIMEDNAME EXR
    awk -v l="$1" -v t="$(cpu "$2")" -v r="$(rtime "$2")" -v f="$3" \
        '$1 == f {printf "%-18s %8s %10.3f %8.3f %8.3f %8.3f\n", l, t, r, $2, $3, $4}' de.txt
}
row "piecewise-linear" pl pl.exr
for n in $BANDS; do row "$n bands" "b$n" "b$n.exr"; done
printf "%-18s %8s %10.3f\n" "4000 bands (ref)" "$(cpu ref)" "$(rtime ref)"
grep -h "linear pieces projected\|pieces on average" pl.log plcount.log | sed 's/^/  /'
# The smallest band counts that reach Delta E 2000 < 1 (every pixel; 99 % of the pixels), and
# their CPU time over the piecewise-linear render's.
for col in 4 3; do
    best=""
    for n in $BANDS; do
        v=$(awk -v f="b$n.exr" -v c=$col '$1 == f {print $c}' de.txt)
        if awk -v p="$v" 'BEGIN {exit !(p < 1)}'; then best=$n; break; fi
    done
    what=$([[ $col == 4 ]] && echo "max dE < 1 (every pixel)" || echo "p99 dE < 1")
    if [[ -n $best ]]; then
        echo "  fewest bands with $what: $best; over piecewise-linear: CPU time" \
             "$(awk -v a="$(cpu "b$best")" -v b="$(cpu pl)" 'BEGIN {printf "%.2fx", a / b}'), render time" \
             "$(awk -v a="$(rtime "b$best")" -v b="$(rtime pl)" 'BEGIN {printf "%.2fx", a / b}')"
    else
        echo "  no band count up to 2560 reaches $what"
    fi
done
