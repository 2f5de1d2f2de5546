#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The reference path tracer on coloured (CCM) dust, two builds side by side: how much faster
# is one build than the other to the same noise?
#
#   bench/path_coloured.sh BEFORE_TOOLS AFTER_TOOLS        (folders holding nebrender)
#   RES=64 IMAGE=96x96 SPP=256 DENSITY=16000 bench/path_coloured.sh /tmp/before/build/tools build/tools
#
# The scene: nebgen --res RES --density DENSITY --emission 0 (the example's shape at tau_V ~3
# through the centre), default dust (CCM89, R_V 3.1, albedo 0.6, HG g 0.6), star sprites off,
# rendered by each build's nebrender --integrator path --spp SPP. Noise: the relative standard
# error of the pixels, sqrt(mean(variance / value^2)) over the pixels above 1 % of the
# maximum, from the image's own variance layer (bench/exr_compare, ref_noise), per channel
# R, G, B and luminance Y. Cost: CPU seconds of the whole nebrender run (/usr/bin/time).
# Efficiency = 1 / (noise^2 x CPU time), the inverse of the time to a given noise; the table
# gives each build's figures and the ratio AFTER / BEFORE of efficiency (> 1: AFTER is
# faster to the same noise). Both builds render the same file with the same seed.
set -euo pipefail
SCRIPT=path_coloured.sh
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
source "$here/common.sh"
[[ $# -eq 2 ]] || { echo "usage: bench/path_coloured.sh BEFORE_TOOLS AFTER_TOOLS" >&2; exit 2; }
before=$(cd "$1" && pwd)
after=$(cd "$2" && pwd)
COMPARE=${COMPARE:-$root/build/bench/exr_compare}
RES=${RES:-64}
IMAGE=${IMAGE:-96x96}
SPP=${SPP:-256}
DENSITY=${DENSITY:-16000}
bench_require "$before/nebrender" "$after/nebrender" "$after/nebgen" "$after/nebillum" "$COMPARE"
bench_tmpdir

timed gen "$after/nebgen" --res "$RES" --emission 0 --density "$DENSITY" -o nebula.vdb
timed illum "$after/nebillum" -i nebula.vdb -o lit.vdb
echo "| build | R noise | G noise | B noise | Y noise | CPU s | efficiency ratio R / G / B / Y (after / before) |"
echo "|---|---|---|---|---|---|---|"
declare -A noise cpus
for b in before after; do
    tools=$before
    [[ $b == after ]] && tools=$after
    timed "$b" "$tools/nebrender" -i lit.vdb --no-stars --res "$IMAGE" --integrator path \
        --spp "$SPP" -o "$b.exr" --no-png
    # exr_compare A A: the ref_noise column (7th) of R, G, B, Y
    noise[$b]=$("$COMPARE" "$b.exr" "$b.exr" | awk '$1 == "R" || $1 == "G" || $1 == "B" || $1 == "Y" { printf "%s ", $7 }')
    cpus[$b]=$(cpu "$b")
done
for b in before after; do
    read -r nr ng nb ny <<<"${noise[$b]}"
    ratio=""
    if [[ $b == after ]]; then
        read -r br bg bb by <<<"${noise[before]}"
        ratio=$(awk -v c0="${cpus[before]}" -v c1="${cpus[after]}" \
            -v a="$nr $ng $nb $ny" -v z="$br $bg $bb $by" 'BEGIN {
            split(a, x, " "); split(z, y, " "); s = "";
            for (i = 1; i <= 4; ++i) s = s sprintf("%s%.2f", i > 1 ? " / " : "", (y[i] * y[i] * c0) / (x[i] * x[i] * c1));
            print s }')
    fi
    printf '| %s | %.4f | %.4f | %.4f | %.4f | %s | %s |\n' "$b" "$nr" "$ng" "$nb" "$ny" "${cpus[$b]}" "$ratio"
done
