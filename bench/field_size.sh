#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The size of nebscatter's field file against its noise, per stored precision (--precision,
# DESIGN §5b "Stored precision"), on nebgen's presets: for each preset the pipeline
#   nebgen --preset P --res RES [| nebionize] | nebillum | nebscatter -v --precision X
# (pillars, bubble and hii pass through nebionize first, as Makefile.data's IONISE), one
# field per precision with the same seed (the same field, stored differently), then each
# rendered (nebrender, IMAGE pixels) and compared with the float field's frame
# (bench/exr_compare --percentile 50 --max: the luminance's relative RMS and largest change
# over the pixels above 1 % of the median), beside the field's own pixel noise (the float
# field against one of --seed 2: their relative RMS difference / sqrt(2)).
#
#   bench/field_size.sh                          # reflection and pillars at 256^3
#   PRESETS=reflection RES=128 bench/field_size.sh
# Environment: PRESETS ("reflection pillars"), RES (256), IMAGE (256x256), PRECISIONS
#   ("float 8"), NOISE=0 skips the second seed, SCATTER_FLAGS, THREADS (0: all cores),
#   BIN (build/tools), KEEP=1 keeps the temp dir (under /tmp).
set -euo pipefail
SCRIPT=field_size.sh
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
source "$here/common.sh"
BIN=${BIN:-$root/build/tools}
COMPARE=${COMPARE:-$root/build/bench/exr_compare}
PRESETS=${PRESETS:-"reflection pillars"}
RES=${RES:-256}
IMAGE=${IMAGE:-256x256}
PRECISIONS=${PRECISIONS:-"float 8"}
NOISE=${NOISE:-1}
SCATTER_FLAGS=${SCATTER_FLAGS:-}
THREADS=${THREADS:-0}
bench_require "$BIN/nebgen" "$BIN/nebionize" "$BIN/nebillum" "$BIN/nebscatter" "$BIN/nebrender" \
    "$COMPARE"
bench_tmpdir
read -r -a sflags <<<"$SCATTER_FLAGS"

mb() { awk -v b="$(stat -c %s "$1")" 'BEGIN { printf "%.1f", b / 1e6 }'; }
# luminance relative RMS and max (percent) of TEST against REF
change() {
    "$COMPARE" "$1" "$2" --percentile 50 --max |
        awk '$1 == "Y" { for (i = 1; i < NF; ++i) if ($i == "max") m = $(i + 1);
                         printf "%.2f %% / %.1f %%", 100 * $5, 100 * m }'
}

echo "machine: $(nproc) cores; load average $(cut -d' ' -f1-3 /proc/loadavg)"
echo "nebscatter flags: ${sflags[*]:-(defaults)}; RES $RES, IMAGE $IMAGE"
echo
echo "| preset | lit input | precision | field file | of float | noise of J | frame change (Y rms / max) | field's pixel noise |"
echo "|---|---|---|---|---|---|---|---|"
for preset in $PRESETS; do
    timed "$preset-gen" "$BIN/nebgen" --preset "$preset" --res "$RES" --threads "$THREADS" \
        -o "$preset.vdb"
    input=$preset.vdb
    case $preset in
        pillars | bubble | hii)
            timed "$preset-ion" "$BIN/nebionize" -i "$input" --threads "$THREADS" \
                -o "$preset-ion.vdb"
            input=$preset-ion.vdb
            ;;
    esac
    timed "$preset-lit" "$BIN/nebillum" -i "$input" --threads "$THREADS" -o "$preset-lit.vdb"
    noise=""
    if [[ $NOISE == 1 ]]; then
        timed "$preset-seed2" "$BIN/nebscatter" -i "$preset-lit.vdb" --seed 2 --precision float \
            "${sflags[@]}" --threads "$THREADS" -o "$preset-seed2.vdb"
        timed "$preset-r-seed2" "$BIN/nebrender" -i "$preset-seed2.vdb" --res "$IMAGE" \
            --threads "$THREADS" -o "$preset-seed2.exr"
    fi
    floatSize=
    for p in $PRECISIONS; do
        timed "$preset-$p" "$BIN/nebscatter" -i "$preset-lit.vdb" --precision "$p" "${sflags[@]}" \
            --threads "$THREADS" -v -o "$preset-$p.vdb"
        timed "$preset-r-$p" "$BIN/nebrender" -i "$preset-$p.vdb" --res "$IMAGE" \
            --threads "$THREADS" -o "$preset-$p.exr"
        size=$(stat -c %s "$preset-$p.vdb")
        [[ -n $floatSize ]] || floatSize=$size
        nj=$(sed -n 's/.*noise of J \([0-9.]*\) %.*/\1 %/p' "$preset-$p.log" | head -n 1)
        first=${PRECISIONS%% *}
        ch=$(change "$preset-$first.exr" "$preset-$p.exr")
        [[ $NOISE == 1 ]] &&
            noise=$("$COMPARE" "$preset-$first.exr" "$preset-seed2.exr" --percentile 50 |
                awk '$1 == "Y" { printf "%.2f %%", 100 * $5 / sqrt(2) }')
        printf "| %s | %s MB | %s | %s MB | %.0f %% | %s | %s | %s |\n" "$preset" \
            "$(mb "$preset-lit.vdb")" "$p" "$(mb "$preset-$p.vdb")" \
            "$(awk -v a="$size" -v b="$floatSize" 'BEGIN { print 100 * a / b }')" "$nj" "$ch" \
            "${noise:-}"
    done
done
echo
echo "field file: nebscatter's output (the lit input's grids passed through plus the field);"
echo "'of float': against the first precision (PRECISIONS). Frame change: bench/exr_compare"
echo "--percentile 50 of the first precision's frame and this one's, luminance."
