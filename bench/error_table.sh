#!/usr/bin/env bash
# The error of the fast method against the reference path tracer (DESIGN §5-6).
#
#   bench/error_table.sh                 # prints a markdown table; figures to examples/
#   RES=64 IMAGE=96x96 THIN_SPP=8192 SPP=1024 THICK_SPP=512 LEVELS="3 5" KEEP=1 bench/error_table.sh
#
# Three nebulae from nebgen (the example's shape, no gas emission) at three densities:
#   thin      --density 600     (peak voxel tau_V ~0.04, whole cloud tau_V < 0.3)
#   moderate  --density 16000   (tau_V ~3 through the centre)
#   thick     --density 160000  (tau_V ~30 through the centre)
# each rendered (star sprites off: scattered light only) by the reference path tracer
# (--integrator path, SPP walks per pixel and channel) and by the fast integrator with single
# scattering only, with the phase table (gain), and with the table plus LEVELS pyramid levels.
# For each: relative error of the total scattered flux (luminance Y), and the relative RMS
# error over the pixels where the reference is above 1 % of its maximum: as measured, and
# with the reference's own noise (its variance layer) taken out, sqrt(RMS^2 - noise^2)
# (bench/exr_compare); "< noise" where the error is below the reference's noise. Figures: examples/error-<scene>.png,
# side by side: reference | single scattering | table | table + most levels (same exposure).
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
THICK_SPP=${THICK_SPP:-512}  # the thick reference's walks are long
THIN_SPP=${THIN_SPP:-8192}   # few walks scatter in the thin cloud: noisy, but cheap
LEVELS=${LEVELS:-"3 5"}
FIGURES=${FIGURES:-$root/examples}
bench_require "$BIN/nebgen" "$BIN/nebillum" "$BIN/nebpyramid" "$BIN/nebphase" "$BIN/nebrender" "$COMPARE"
bench_tmpdir

maxLevel=0
for L in $LEVELS; do (( L > maxLevel )) && maxLevel=$L; done
timed phase "$BIN/nebphase" -o phase.vdb
echo "| scene | centre tau_V | mode | flux error | pixel RMS error (measured / noise removed) | render time |"
echo "|---|---|---|---|---|---|"
for scene in "thin 600" "moderate 16000" "thick 160000"; do
    set -- $scene
    name=$1 density=$2
    timed gen "$BIN/nebgen" --res "$RES" --emission 0 --density "$density" -o "$name.vdb"
    timed illum "$BIN/nebillum" -i "$name.vdb" -o "$name-lit.vdb"
    timed pyr "$BIN/nebpyramid" -i "$name-lit.vdb" --levels "$maxLevel" -o "$name-pyr.vdb"
    common=(-i "$name-pyr.vdb" --no-stars --res "$IMAGE")
    spp=$SPP
    [[ $name == thick ]] && spp=$THICK_SPP
    [[ $name == thin ]] && spp=$THIN_SPP
    timed "$name-ref" "$BIN/nebrender" "${common[@]}" --integrator path --spp "$spp" \
        -o "$name-ref.exr" --png "$name-ref.png"
    # One exposure for all the figures: the reference's automatic tone curve.
    white=$(strings "$name-ref.exr" | grep -o '"white": [0-9.e+-]*' | head -1 | awk '{print $2}')
    gamma=$(strings "$name-ref.exr" | grep -o '"gamma": [0-9.e+-]*' | head -1 | awk '{print $2}')
    exposure=$(awk -v w="$white" 'BEGIN { print -log(w) / log(2) }')
    tone=(--exposure "$exposure" --gamma "$gamma")
    tau=$("$COMPARE" "$name-ref.exr" "$name-ref.exr" | awk '/centre pixel optical depth/ { print $(NF-1) }')
    modes=("single::" "table:--phase phase.vdb --levels 0:")
    for L in $LEVELS; do modes+=("table + $L levels:--phase phase.vdb --levels $L:"); done
    pngs=("$name-ref.png")
    for m in "${modes[@]}"; do
        label=${m%%:*}; rest=${m#*:}; flags=${rest%%:*}
        tag=$(echo "$label" | tr -c 'a-z0-9' '_')
        # shellcheck disable=SC2086
        timed "$name-$tag" "$BIN/nebrender" "${common[@]}" $flags "${tone[@]}" \
            -o "$name-$tag.exr" --png "$name-$tag.png"
        [[ $label == "single" || $label == "table" || $label == "table + $maxLevel levels" ]] && pngs+=("$name-$tag.png")
        line=$("$COMPARE" "$name-ref.exr" "$name-$tag.exr" | awk '$1 == "Y"')
        flux=$(awk '{ printf "%+.1f %%", 100 * $4 }' <<<"$line")
        rms=$(awk '{ if ($8 > 0) printf "%.1f %% / %.1f %%", 100 * $5, 100 * $8;
                     else printf "%.1f %% / < noise", 100 * $5 }' <<<"$line")
        echo "| $name | $tau | $label | $flux | $rms | $(wall "$name-$tag") s |"
    done
    noise=$("$COMPARE" "$name-ref.exr" "$name-ref.exr" | awk '$1 == "Y" { printf "%.1f %%", 100 * $7 }')
    echo "| $name | $tau | reference ($spp spp) | | noise $noise | $(wall "$name-ref") s |"
    python3 "$here/tile_png.py" "$FIGURES/error-$name.png" "${pngs[@]}"
done
