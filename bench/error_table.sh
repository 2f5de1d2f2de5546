#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The error of the fast methods against the reference path tracer (DESIGN §5, 5b, 6).
#
#   bench/error_table.sh                 # prints a markdown table; figures to examples/
#   RES=64 IMAGE=96x96 SPP=1024 THICK_SPP=512 PACKETS=2000000 SCENES="moderate side" KEEP=1 bench/error_table.sh
#   SCENES="thick filaments" METHODS="field default,single" REF2=1 bench/error_table.sh
#
# Five nebulae from nebgen (the example's shape, no gas emission):
#   thin       --density 600     (peak voxel tau_V ~0.04, whole cloud tau_V < 0.3)
#   moderate   --density 16000   (tau_V ~3 through the centre)
#   thick      --density 160000  (tau_V ~30 through the centre)
#   side       --density 16000, one B star outside the cloud lighting it from the side
#   filaments  --density 60000 --exponent 3 --contrast 4 --frequency 2.5: dense filaments
#              casting deep shadows
# each rendered (star sprites off: scattered light only) by the reference path tracer
# (--integrator path, SPP walks per pixel) and by the fast integrator: single
# scattering; the seed's method (phase table + LEVELS pyramid levels); and nebscatter's field
# at order L = 1, 2, 3 on cells of 2 voxels (level 1), at L = 2 on full resolution (level 0)
# and cells of 4 voxels (level 2), and at its defaults (L = 4, --field-level auto: the row
# names the level chosen; adaptive cells, --refine-tau 1) and with uniform cells
# (--refine-tau 0), PACKETS packets each.
# For each: relative error of the total scattered flux (luminance Y), and the relative RMS
# error over the pixels where the reference is above 1 % of its maximum: as measured, and
# with the reference's own noise (its variance layer) taken out, sqrt(RMS^2 - noise^2)
# (bench/exr_compare); "< noise" where the error is below the reference's noise; the same
# over blocks of 8x8 pixels (exr_compare --block 8: the image's error on that scale, with 8
# times less of the reference's noise in it); the
# precompute's wall time and peak RSS (nebscatter, or nebpyramid + nebphase), and the render's.
# METHODS: only the methods whose label starts with one of these, comma-separated (default:
# all).
# REF2=1: a second reference with another seed, and two more columns, the error measured
# against both (exr_compare --second-reference: the mean of (TEST - REF)(TEST - REF2), whose
# references' noises are independent, so no noise estimate enters it).
# Figures: examples/error-<scene>.png, side by side: reference | single scattering | seed's
# method | field (the defaults), at the reference's exposure.
set -euo pipefail
SCRIPT=error_table.sh
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
source "$here/common.sh"
BIN=${BIN:-$root/build/tools}
COMPARE=${COMPARE:-$root/build/bench/exr_compare}
RES=${RES:-64}
IMAGE=${IMAGE:-96x96}
SPP=${SPP:-1024}
THICK_SPP=${THICK_SPP:-512} # the thick reference's walks are long
THIN_SPP=${THIN_SPP:-8192}  # few walks scatter in the thin cloud: noisy, but cheap
LEVELS=${LEVELS:-5}
PACKETS=${PACKETS:-2000000}
SCENES=${SCENES:-"thin moderate thick side filaments"}
METHODS=${METHODS:-}
REF2=${REF2:-0}
FIGURES=${FIGURES:-$root/examples}
bench_require "$BIN/nebgen" "$BIN/nebillum" "$BIN/nebpyramid" "$BIN/nebphase" "$BIN/nebscatter" \
    "$BIN/nebrender" "$COMPARE"
bench_tmpdir

# "measured / noise removed" from an exr_compare line (columns 5 and 8).
rms_pair() {
    awk '{ if ($8 > 0) printf "%.1f %% / %.1f %%", 100 * $5, 100 * $8;
           else printf "%.1f %% / < noise", 100 * $5 }' <<<"$1"
}

timed phase "$BIN/nebphase" -o phase.vdb
two_refs_head="" two_refs_rule=""
if [[ $REF2 == 1 ]]; then
    two_refs_head=" pixel RMS error, two references | 8x8-block RMS error, two references |"
    two_refs_rule="---|---|"
fi
echo "| scene | centre tau_V | method | flux error | pixel RMS error (measured / noise removed) | 8x8-block RMS error (measured / noise removed) |$two_refs_head precompute | peak RSS | render |"
echo "|---|---|---|---|---|---|$two_refs_rule---|---|---|"
for name in $SCENES; do
    case $name in
        thin) gen=(--density 600) ;;
        moderate) gen=(--density 16000) ;;
        thick) gen=(--density 160000) ;;
        side) gen=(--density 16000 --star "side:-9,1.5,0:40000:B1V") ;;
        filaments) gen=(--density 60000 --exponent 3 --contrast 4 --frequency 2.5) ;;
        *) echo "$SCRIPT: error: unknown scene $name" >&2; exit 1 ;;
    esac
    timed gen "$BIN/nebgen" --res "$RES" --emission 0 "${gen[@]}" -o "$name.vdb"
    timed illum "$BIN/nebillum" -i "$name.vdb" -o "$name-lit.vdb"
    timed "$name-pyr" "$BIN/nebpyramid" -i "$name-lit.vdb" --levels "$LEVELS" -o "$name-pyr.vdb"
    spp=$SPP
    [[ $name == thick ]] && spp=$THICK_SPP
    [[ $name == thin ]] && spp=$THIN_SPP
    timed "$name-ref" "$BIN/nebrender" -i "$name-lit.vdb" --no-stars --res "$IMAGE" \
        --integrator path --spp "$spp" -o "$name-ref.exr" --png "$name-ref.png"
    if [[ $REF2 == 1 ]]; then
        timed "$name-ref2" "$BIN/nebrender" -i "$name-lit.vdb" --no-stars --res "$IMAGE" \
            --integrator path --spp "$spp" --seed 2 -o "$name-ref2.exr" --no-png
    fi
    # One exposure for all the figures: the reference's automatic tone curve.
    white=$(strings "$name-ref.exr" | grep -o '"white": *[0-9.e+-]*' | head -1 | awk -F: '{print $2}')
    gamma=$(strings "$name-ref.exr" | grep -o '"gamma": *[0-9.e+-]*' | head -1 | awk -F: '{print $2}')
    exposure=$(awk -v w="$white" 'BEGIN { print -log(w) / log(2) }')
    tone=(--exposure "$exposure" --gamma "$gamma")
    tau=$("$COMPARE" "$name-ref.exr" "$name-ref.exr" | awk '/centre pixel optical depth/ { print $(NF-1) }')
    # label : precompute (nebscatter flags, or "pyr" / "none") : render input : render flags
    modes=("single:none:$name-lit.vdb:"
           "table + $LEVELS levels:pyr:$name-pyr.vdb:--phase phase.vdb --levels $LEVELS"
           "field L=1:--order 1 --field-level 1::" "field L=2:--order 2 --field-level 1::"
           "field L=3:--order 3 --field-level 1::"
           "field L=2 level 0:--order 2 --field-level 0::"
           "field L=2 level 2:--order 2 --field-level 2::"
           "field default:-v::" "field uniform cells:-v --refine-tau 0::")
    pngs=("$name-ref.png")
    for m in "${modes[@]}"; do
        IFS=: read -r label pre input flags <<<"$m"
        if [[ -n $METHODS ]]; then
            keep=0
            IFS=, read -ra words <<<"$METHODS"
            for w in "${words[@]}"; do [[ $label == "$w"* ]] && keep=1; done
            # shellcheck disable=SC2015
            ((keep)) || continue
        fi
        tag=$(echo "$label" | tr -c 'a-z0-9' '_')
        precompute="" rss=""
        if [[ $pre == pyr ]]; then
            precompute="$(awk -v a="$(wall "$name-pyr")" -v b="$(wall phase)" 'BEGIN { printf "%.3g", a + b }') s"
            rss="$(( $(maxrss "$name-pyr") / 1024 )) MiB"
        elif [[ $pre != none ]]; then
            input="$name-$tag.vdb"
            # shellcheck disable=SC2086
            timed "$name-$tag-scatter" "$BIN/nebscatter" -i "$name-lit.vdb" --packets "$PACKETS" \
                $pre -o "$input"
            precompute="$(wall "$name-$tag-scatter") s"
            # The defaults: name the level nebscatter chose (-v).
            [[ $label == "field default" || $label == "field uniform cells" ]] && label="$label (L=4, level $(grep -o \
                'field level -\?[0-9]* chosen' "$name-$tag-scatter.log" | awk '{ print $3 }'))"
            rss="$(( $(maxrss "$name-$tag-scatter") / 1024 )) MiB"
        fi
        # shellcheck disable=SC2086
        timed "$name-$tag" "$BIN/nebrender" -i "$input" --no-stars --res "$IMAGE" $flags \
            "${tone[@]}" -o "$name-$tag.exr" --png "$name-$tag.png"
        [[ $label == "single" || $label == "table + $LEVELS levels" || $label == "field default"* ]] &&
            pngs+=("$name-$tag.png")
        line=$("$COMPARE" "$name-ref.exr" "$name-$tag.exr" | awk '$1 == "Y"')
        flux=$(awk '{ printf "%+.1f %%", 100 * $4 }' <<<"$line")
        rms=$(rms_pair "$line")
        block=$(rms_pair "$("$COMPARE" "$name-ref.exr" "$name-$tag.exr" --block 8 | awk '$1 == "Y"')")
        two=""
        if [[ $REF2 == 1 ]]; then
            for b in 1 8; do
                two+=" $("$COMPARE" "$name-ref.exr" "$name-$tag.exr" --block $b \
                    --second-reference "$name-ref2.exr" |
                    awk '$1 == "Y" { printf "%.1f %%", 100 * $9 }') |"
            done
        fi
        echo "| $name | $tau | $label | $flux | $rms | $block |$two $precompute | $rss | $(wall "$name-$tag") s |"
    done
    noise=$("$COMPARE" "$name-ref.exr" "$name-ref.exr" | awk '$1 == "Y" { printf "%.1f %%", 100 * $7 }')
    bnoise=$("$COMPARE" "$name-ref.exr" "$name-ref.exr" --block 8 |
        awk '$1 == "Y" { printf "%.1f %%", 100 * $7 }')
    two=""
    [[ $REF2 == 1 ]] && two=" | |"
    echo "| $name | $tau | reference ($spp spp) | | noise $noise | noise $bnoise |$two | | $(wall "$name-ref") s |"
    # The figures need every method (not with METHODS).
    [[ -n $METHODS ]] || python3 "$here/tile_png.py" "$FIGURES/error-$name.png" "${pngs[@]}"
done
