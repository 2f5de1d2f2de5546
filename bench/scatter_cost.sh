#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# nebscatter's cost per star against its image noise, on 128^3 scenes that are hard for it
# (bench/error_table.sh's nebula shape, one star inside, no gas emission):
#   moderate  --density 16000   (tau_V 3-4 through the centre)
#   dense     --density 128000  (the same cloud 8x denser)
# For each: nebscatter's wall time and peak memory (/usr/bin/time -v), its flights per packet
# and noise of J (-v), and the image noise of the field: the cloud rendered (512x512, star
# sprites off) from two fields of different seeds; the relative RMS difference of the two
# over the pixels above 1 % of the maximum (bench/exr_compare), divided by sqrt(2), is one
# field's pixel noise (8x8 blocks: the same over blocks; "faint": over the pixels above 0.1 %
# of the maximum, the dim parts behind thick dust included). The render with the field against
# single scattering (--no-scatter-field), RUNS renders each, gives the field's render cost.
#
#   bench/scatter_cost.sh                       # both scenes, the defaults
#   SCENES=dense PACKETS=500000 SCATTER_FLAGS="--order 2" bench/scatter_cost.sh
# Environment: RES (128), IMAGE (512x512), PACKETS (nebscatter's default if empty),
#   SCATTER_FLAGS (more nebscatter options), THREADS (0: all cores), RUNS (3), SCENES,
#   BIN (build/tools), KEEP=1 keeps the temp dir.
set -euo pipefail
SCRIPT=scatter_cost.sh
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
source "$here/common.sh"
BIN=${BIN:-$root/build/tools}
COMPARE=${COMPARE:-$root/build/bench/exr_compare}
RES=${RES:-128}
IMAGE=${IMAGE:-512x512}
PACKETS=${PACKETS:-}
SCATTER_FLAGS=${SCATTER_FLAGS:-}
THREADS=${THREADS:-0}
RUNS=${RUNS:-3}
SCENES=${SCENES:-"moderate dense"}
bench_require "$BIN/nebgen" "$BIN/nebillum" "$BIN/nebscatter" "$BIN/nebrender" "$COMPARE"
bench_tmpdir
read -r -a sflags <<<"$SCATTER_FLAGS"
[[ -z $PACKETS ]] || sflags+=(--packets "$PACKETS")

echo "machine: $(nproc) cores, $(awk '/MemTotal/ { printf "%.1f GiB", $2 / 1048576 }' /proc/meminfo); load average $(cut -d' ' -f1-3 /proc/loadavg)"
echo "nebscatter flags: ${sflags[*]:-(defaults)}"
echo
echo "| scene | centre tau_V | nebscatter | peak RSS | flights/packet | noise of J | pixel noise | 8x8-block noise | pixel noise, faint | render: field / single |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for name in $SCENES; do
    case $name in
        moderate) gen=(--density 16000) ;;
        dense) gen=(--density 128000) ;;
        *) echo "$SCRIPT: error: unknown scene $name" >&2; exit 1 ;;
    esac
    timed gen "$BIN/nebgen" --res "$RES" --emission 0 "${gen[@]}" \
        --star "alpha:0.4,0.3,-0.2:8000:B1V" --threads "$THREADS" -o "$name.vdb"
    timed illum "$BIN/nebillum" -i "$name.vdb" --threads "$THREADS" -o "$name-lit.vdb"
    for seed in 1 2; do
        timed "$name-s$seed" "$BIN/nebscatter" -i "$name-lit.vdb" --seed $seed "${sflags[@]}" \
            --threads "$THREADS" -v -o "$name-s$seed.vdb"
        timed "$name-r$seed" "$BIN/nebrender" -i "$name-s$seed.vdb" --no-stars --res "$IMAGE" \
            --threads "$THREADS" -o "$name-r$seed.exr"
    done
    fast=() single=()
    for ((i = 1; i <= RUNS; ++i)); do
        timed "$name-rf$i" "$BIN/nebrender" -i "$name-s1.vdb" --no-stars --res "$IMAGE" \
            --threads "$THREADS" -v -o "$name-rf.exr"
        timed "$name-rs$i" "$BIN/nebrender" -i "$name-s1.vdb" --no-stars --res "$IMAGE" \
            --no-scatter-field --threads "$THREADS" -v -o "$name-rs.exr"
        fast+=("$(sed -n 's/.*, render \([0-9.]*\) s,.*/\1/p' "$name-rf$i.log" | head -n 1)")
        single+=("$(sed -n 's/.*, render \([0-9.]*\) s,.*/\1/p' "$name-rs$i.log" | head -n 1)")
    done
    tau=$("$COMPARE" "$name-r1.exr" "$name-r1.exr" | awk '/centre pixel optical depth/ { print $(NF-1) }')
    pix=$("$COMPARE" "$name-r1.exr" "$name-r2.exr" | awk '$1 == "Y" { printf "%.2f %%", 100 * $5 / sqrt(2) }')
    blk=$("$COMPARE" "$name-r1.exr" "$name-r2.exr" --block 8 | awk '$1 == "Y" { printf "%.2f %%", 100 * $5 / sqrt(2) }')
    faint=$("$COMPARE" "$name-r1.exr" "$name-r2.exr" --threshold 0.001 |
        awk '$1 == "Y" { printf "%.2f %%", 100 * $5 / sqrt(2) }')
    fpp=$(sed -n 's/.*stars: [0-9]* packets, [0-9]* flights (\([0-9.]*\) per packet).*/\1/p' "$name-s1.log")
    noise=$(sed -n 's/.*noise of J \([0-9.]*\) %.*/\1 %/p' "$name-s1.log" | head -n 1)
    ratio=$(printf '%s\n' "${fast[@]}" | sort -n | sed -n "$(((RUNS + 1) / 2))p")
    sratio=$(printf '%s\n' "${single[@]}" | sort -n | sed -n "$(((RUNS + 1) / 2))p")
    printf "| %s | %s | %.1f s / %.1f s | %.0f MiB | %s | %s | %s | %s | %s | %s / %s s = %.2fx |\n" \
        "$name" "$tau" "$(wall "$name-s1")" "$(wall "$name-s2")" \
        "$(awk -v k="$(maxrss "$name-s1")" 'BEGIN { print k / 1024 }')" "$fpp" "$noise" "$pix" "$blk" "$faint" \
        "$ratio" "$sratio" "$(awk -v a="$ratio" -v b="$sratio" 'BEGIN { print a / b }')"
done
echo
echo "render times: medians of $RUNS (nebrender -v: 'render N s', the frame without the scene); field times: seed 1 / seed 2"
