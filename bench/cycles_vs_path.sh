#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# nebrender's reference path tracer (--integrator path) against Blender Cycles on the same
# scene: is nebrender at least as fast as Cycles to the same noise level?
#
# Usage: bench/cycles_vs_path.sh [TOOLS_DIR]          (default: build/tools)
# Environment: RES (image size; default 128x128), NEB_SPP and CYC_SPP (sample counts of the
#   noise pairs; default "16 64 256 1024" each), REF_SPP (nebrender reference; default 4096),
#   TARGET (relative noise to reach; default 0.05), THRESHOLD (pixels counted: reference
#   above this fraction of its maximum; default 0.01), STEP_RATE (Cycles volume step rate;
#   default 1), CHECK_STEP_RATE and CHECK_SPP (one Cycles render at a finer step against
#   the same seed at STEP_RATE; default 0.1 and 64; CHECK_STEP_RATE=0 skips it),
#   VOLUME_SAMPLING (Cycles material volume sampling: MULTIPLE_IMPORTANCE (default, as
#   Blender's default), DISTANCE or EQUIANGULAR), COLOURED=1 (coloured dust: CCM89 at
#   nebrender's channel wavelengths instead of grey dust at 549.45 nm),
#   BLENDER (default blender), EXR_COMPARE (default build/bench/exr_compare), OUTDIR (copy
#   the comparison PNGs there), KEEP=1 keeps the temp dir.
#
# Requirements, checked before anything runs: nebgen, nebillum, nebrender and exr_compare
# (make -f Makefile.data build), vdb_print (Debian libopenvdb-tools), GNU time (time), Blender
# (blender), and in Blender's Python numpy and PIL (cycles_scene.py reads EXR files with
# numpy and writes the comparison PNGs with PIL: Debian python3-numpy and python3-pil, which
# Debian's Blender uses). Missing Debian packages are installed with apt-get (as root, else
# with sudo), as Makefile.data does; BENCH_INSTALL=0 only names them.
#
# The scene: nebgen --res 64 (10 pc cube), dust only (--emission 0), one B1V star of
# 8000 L_sun at (0.4, 0.3, -0.2) pc; nebrender's default view (eye 4,3,-19, look-at origin,
# up +y, horizontal fov 36 deg), RES pixels.
#   * nebrender: --integrator path --no-stars, all three channels at one wavelength,
#     549.45 nm, where CCM89's A/A_V = 1 exactly (x = 1.82 um^-1; at 546.1 nm it is 1.0071),
#     so sigma_t = kappa_V n_H per pc in every channel: grey dust, albedo 0.6, HG g = 0.6.
#     One random walk per pixel sample serves the three channels (grey here; coloured dust is
#     spectrally tracked, bench/path_coloured.sh).
#   * Cycles (bench/cycles_scene.py): the same VDB as a Volume object; Principled Volume with
#     Density = kappa_V (times the "density" grid), Color = albedo, Absorption Color black
#     (then sigma_t = Density * grid and albedo = Color; see the script), Anisotropy = g; a
#     radius-0 point light of power L [W] and the star's linear sRGB colour (taken from the
#     nebrender reference's channel fluxes; a Cycles point light of P W gives irradiance
#     P / (4 pi r^2), checked on a white Lambertian plane, so radiances match nebrender's
#     L_sun pc^-2 sr^-1 absolutely); the same camera; black world; fixed samples, no
#     adaptive sampling, no denoising, no clamping, 128 bounces, 0.01 px filter.
#     The volume is moved by -1/2 voxel on each axis: Cycles' NanoVDB trilinear lookup reads
#     index (p - 0.5) (intern/cycles/kernel/device/cpu/image.h, interp_3d_linear), i.e. it
#     shows every voxel half a voxel towards +x+y+z of where OpenVDB (and nebrender) put it.
#     Without the shift the converged images differ by ~60 % RMS along every edge.
#   * Noise of a renderer at N samples: two renders, seeds 1 and 2; RMS over the pixels where
#     the reference (nebrender, REF_SPP, seed 1000, scaled to their flux) is above THRESHOLD
#     of its maximum of (A - B) / REF, divided by sqrt(2) (cycles_scene.py --noise), in G
#     (one channel: nebrender's G is one walk per sample, Cycles' one path per sample) and
#     in luminance Y (nebrender's averages three independent walks, Cycles' channels are the
#     same path), and energy-weighted (G; sqrt(sum (A-B)^2 / 2 / sum REF^2), which the faint
#     pixels near THRESHOLD, and Cycles' fireflies there, sway far less).
#     Fit noise = c / sqrt(N) (c: geometric mean of noise sqrt(N) over the runs; the fitted
#     log-log slope shows whether -1/2 holds); samples to TARGET: (c / TARGET)^2; also from a
#     free power law and from the largest N alone. Time per sample b: least squares of render
#     time against N over all runs (the intercept a is the per-render setup). Time to TARGET
#     = b * samples; the answer is the ratio Cycles / nebrender of that, CPU time, G.
#   * Cycles' volume step rate: STEP_RATE 1 (Blender's default; step = 1 voxel): on this
#     scene the converged flux at 1 and at 0.1 agree to 0.01 % (the check below) while 0.1
#     costs ~7x the time, so the default is the setting most favourable to Cycles.
#   * Times: the render phase (nebrender -v "render ... s"; Cycles: bpy.ops.render.render,
#     which includes its scene sync), wall and, on a shared machine more trustworthy, CPU
#     (nebrender: whole process; Cycles: the render call's process CPU time). Both use all
#     cores. Blender's start-up (~0.5 s) is not counted.
set -euo pipefail

TOOLS=${1:-build/tools}
BLENDER=${BLENDER:-blender}
EXR_COMPARE=${EXR_COMPARE:-build/bench/exr_compare}
RES=${RES:-128x128}
NEB_SPP=${NEB_SPP:-16 64 256 1024}
CYC_SPP=${CYC_SPP:-16 64 256 1024}
REF_SPP=${REF_SPP:-4096}
TARGET=${TARGET:-0.05}
THRESHOLD=${THRESHOLD:-0.01}
STEP_RATE=${STEP_RATE:-1}
CHECK_STEP_RATE=${CHECK_STEP_RATE:-0.1}
CHECK_SPP=${CHECK_SPP:-64}
VOLUME_SAMPLING=${VOLUME_SAMPLING:-MULTIPLE_IMPORTANCE}
COLOURED=${COLOURED:-0}

GRID=64; SIZE=10; STAR_POS=0.4,0.3,-0.2; LUMINOSITY=8000; CLASS=B1V
WAVELENGTH=549.450549   # CCM89 x = 1000 / lambda = 1.82 um^-1: A/A_V = 1
EYE=4,3,-19; LOOK_AT=0,0,0; UP=0,1,0; FOV=36

SCRIPT=cycles_vs_path
HERE=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=bench/common.sh
source "$HERE/common.sh"
# --- requirements (see the top) -------------------------------------------------------------
bench_install_debs libopenvdb-tools time   # /usr/bin/vdb_print, /usr/bin/time
[[ $BLENDER != blender ]] || command -v blender >/dev/null || bench_install_debs blender
for exe in "$TOOLS/nebgen" "$TOOLS/nebillum" "$TOOLS/nebrender" "$EXR_COMPARE"; do
    [[ -x $exe ]] || {
        echo "$SCRIPT: error: $exe not found: build it first (make -f Makefile.data build, or cmake --build build --target $(basename "$exe"))" >&2
        exit 1
    }
done
bench_require "$TIME" /usr/bin/vdb_print
command -v "$BLENDER" >/dev/null || { echo "$SCRIPT: error: $BLENDER not found (Debian: apt-get install blender)" >&2; exit 1; }
# Blender's Python modules: prints the missing ones of numpy and PIL, or fails if Blender's
# Python does not run at all.
blender_missing_modules() {
    local out
    if ! out=$("$BLENDER" -b --factory-startup --python-exit-code 1 --python-expr 'import importlib.util
print("missing-modules:", *[m for m in ("numpy", "PIL") if importlib.util.find_spec(m) is None])' 2>&1) ||
        ! grep -q '^missing-modules:' <<<"$out"; then
        echo "$SCRIPT: error: cannot run Python in $BLENDER:" >&2
        echo "$out" | tail -n 5 >&2
        exit 1
    fi
    sed -n 's/^missing-modules: *//p' <<<"$out"
}
deb_of_module() { case $1 in numpy) echo python3-numpy ;; PIL) echo python3-pil ;; esac; }
MODULES=$(blender_missing_modules)
if [[ -n $MODULES ]]; then
    DEBS=$(for m in $MODULES; do deb_of_module "$m"; done | tr '\n' ' ')
    if [[ $(readlink -f "$(command -v "$BLENDER")") == /usr/bin/blender* ]]; then
        # Debian's Blender runs the system Python 3: the Debian packages provide the modules.
        # shellcheck disable=SC2086
        bench_install_debs $DEBS
        MODULES=$(blender_missing_modules)
    fi
    if [[ -n $MODULES ]]; then
        echo "$SCRIPT: error: Blender's Python ($BLENDER) cannot import: $MODULES (Debian packages:" \
            "${DEBS% }; a Blender with its own Python needs them installed into that Python)" >&2
        exit 1
    fi
fi
TOOLS=$(cd "$TOOLS" && pwd)
EXR_COMPARE=$(cd "$(dirname "$EXR_COMPARE")" && pwd)/$(basename "$EXR_COMPARE")
PY=$HERE/cycles_scene.py
[[ -z ${OUTDIR:-} ]] || { mkdir -p "$OUTDIR"; OUTDIR=$(cd "$OUTDIR" && pwd); }
bench_tmpdir
START=$(date +%s)

echo "machine: $(nproc) cores, $(uname -m); load average $(cut -d' ' -f1-3 /proc/loadavg); $("$BLENDER" --version 2>/dev/null | head -n1)"
echo "scene: nebgen --res $GRID, one $CLASS star of $LUMINOSITY L_sun at $STAR_POS pc, no gas; $RES from $EYE to $LOOK_AT, fov $FOV"
echo "Cycles: volume step rate $STEP_RATE, volume sampling $VOLUME_SAMPLING"

timed gen "$TOOLS/nebgen" --res "$GRID" --size "$SIZE" --density 4000 --emission 0 \
    --star "alpha:$STAR_POS:$LUMINOSITY:$CLASS" -o n.vdb
timed illum "$TOOLS/nebillum" -i n.vdb -o lit.vdb

DUST=$(/usr/bin/vdb_print -m n.vdb | sed -n 's/^nebula:dust: //p')
dustField() { echo "$DUST" | grep -o "\"$1\": *[-0-9.eE+]*" | sed 's/.*: *//' || true; }
KAPPA_V=$(dustField kappa_V); ALBEDO=$(dustField albedo); G=$(dustField g)
[[ -n $KAPPA_V && -n $ALBEDO && -n $G ]] ||
    { echo "$SCRIPT: error: no kappa_V/albedo/g in n.vdb's nebula:dust: '$DUST'" >&2; exit 1; }
# Coloured dust (COLOURED=1): nebrender's own channel wavelengths (700, 546.1, 435.8 nm) and
# CCM89's A/A_V there (the optical polynomial, 1.1 <= x <= 3.3 um^-1, with the dust's R_V),
# one walk for the three channels (spectral tracking); Cycles gets per-channel extinction
# (cycles_scene.py --ratios).
RATIOS=1,1,1
NEB_WL=(--wavelengths "$WAVELENGTH,$WAVELENGTH,$WAVELENGTH")
if [[ $COLOURED == 1 ]]; then
    RV=$(dustField R_V)
    [[ -n $RV ]] || { echo "$SCRIPT: error: no R_V in n.vdb's nebula:dust: '$DUST'" >&2; exit 1; }
    RATIOS=$(awk -v rv="$RV" 'function ccm(nm,  x, y, a, b) {
            x = 1000 / nm; y = x - 1.82
            a = 1 + 0.17699*y - 0.50447*y^2 - 0.02427*y^3 + 0.72085*y^4 + 0.01979*y^5 - 0.77530*y^6 + 0.32999*y^7
            b = 1.41338*y + 2.28305*y^2 + 1.07233*y^3 - 5.38434*y^4 - 0.62251*y^5 + 5.30260*y^6 - 2.09002*y^7
            return a + b / rv }
        BEGIN { printf "%.6f,%.6f,%.6f", ccm(700), ccm(546.1), ccm(435.8) }')
    NEB_WL=(--wavelengths 700,546.1,435.8)
fi
HALF=$(awk -v s="$SIZE" -v n="$GRID" 'BEGIN { printf "%.9g", -0.5 * s / n }')
echo "dust: kappa_V $KAPPA_V pc^-1 cm^3 (sigma_t = kappa_V n_H at $WAVELENGTH nm), albedo $ALBEDO, g $G; voxel $(awk -v s="$SIZE" -v n="$GRID" 'BEGIN { print s / n }') pc"
[[ $COLOURED != 1 ]] || echo "coloured dust: A/A_V $RATIOS at 700, 546.1, 435.8 nm (CCM89, R_V $RV)"

# --- runs ---------------------------------------------------------------------------------
NEB_VIEW=(--res "$RES" --eye "$EYE" --look-at "$LOOK_AT" --up "$UP" --fov "$FOV")
neb() {  # neb NAME SPP SEED: sets RW, RC (render wall, process CPU [s])
    timed "$1" "$TOOLS/nebrender" -i lit.vdb --integrator path --spp "$2" --seed "$3" \
        "${NEB_WL[@]}" --no-stars "${NEB_VIEW[@]}" \
        -o "$1.exr" --no-png -v
    RW=$(sed -n 's/.*render \([0-9.eE+-]*\) s.*/\1/p' "$1.log" | head -n1)
    RC=$(cpu "$1")
    [[ -n $RW ]] || { echo "$SCRIPT: error: no 'render ... s' in nebrender -v:" >&2; cat "$1.log" >&2; exit 1; }
}
cyc() {  # cyc NAME SPP SEED STEP_RATE: sets RW, RC (render call wall, CPU [s])
    timed "$1" "$BLENDER" -b --factory-startup --python-exit-code 1 --python "$PY" -- \
        --vdb n.vdb -o "$1.exr" --samples "$2" --seed "$3" --res "$RES" --eye "$EYE" \
        --look-at "$LOOK_AT" --up "$UP" --fov "$FOV" --offset="$HALF,$HALF,$HALF" \
        --light "$STAR_POS" --power "$LUMINOSITY" --light-color "$STAR_RGB" \
        --sigma-t "$KAPPA_V" --ratios "$RATIOS" --albedo "$ALBEDO" --g "$G" --step-rate "$4" \
        --volume-sampling "$VOLUME_SAMPLING"
    local line
    line=$(grep '^cycles: render' "$1.log" | head -n1)
    [[ -n $line ]] || { echo "$SCRIPT: error: no 'cycles: render' line from Blender:" >&2; cat "$1.log" >&2; exit 1; }
    RW=$(echo "$line" | awk '{ print $3 }'); RC=$(echo "$line" | awk '{ print $6 }')
}
noise() {  # noise NAME REF A B [--png FILE]: the lines "noise CH ..." of cycles_scene.py --noise
    local name=$1; shift
    timed "$name" "$BLENDER" -b --factory-startup --python-exit-code 1 --python "$PY" -- \
        --noise "$@" --threshold "$THRESHOLD"
    grep '^noise ' "$name.log"
}
# field NAME CH KEY: from NAME.log's line "noise CH VALUE key value ...", VALUE (KEY noise) or
# the value after KEY.
field() {
    awk -v c="$2" -v k="$3" '$1 == "noise" && $2 == c {
        if (k == "noise") { print $3; exit }
        for (i = 4; i < NF; ++i) if ($i == k) { print $(i + 1); exit } }' "$1.log"
}

echo
echo "nebrender reference: $REF_SPP spp, seed 1000"
neb ref "$REF_SPP" 1000
echo "  render $RW s wall, process $RC s CPU"
# The star's linear sRGB colour (luminance 1): the channel fluxes over the Y flux of the
# light scattered once by grey dust (the fast integrator: exact and quick; in grey dust the
# scattered light has the star's colour).
timed colour "$TOOLS/nebrender" -i lit.vdb --wavelengths "$WAVELENGTH,$WAVELENGTH,$WAVELENGTH" \
    --no-stars "${NEB_VIEW[@]}" -o colour.exr --no-png
"$EXR_COMPARE" colour.exr colour.exr >refflux.txt
STAR_RGB=$(awk '$1 == "R" { r = $2 } $1 == "G" { g = $2 } $1 == "B" { b = $2 } $1 == "Y" { y = $2 }
                END { printf "%.6f,%.6f,%.6f", r / y, g / y, b / y }' refflux.txt)
echo "  star colour (channel flux / luminance flux): $STAR_RGB"

printf '\n%-10s %6s %5s %10s %10s\n' renderer spp seed "wall [s]" "CPU [s]"
: >runs.txt
for n in $NEB_SPP; do
    for s in 1 2; do
        neb "neb_${n}_$s" "$n" "$s"
        printf '%-10s %6d %5d %10.3f %10.3f\n' nebrender "$n" "$s" "$RW" "$RC"
        echo "neb $n $s $RW $RC" >>runs.txt
    done
done
for n in $CYC_SPP; do
    for s in 1 2; do
        cyc "cyc_${n}_$s" "$n" "$s" "$STEP_RATE"
        printf '%-10s %6d %5d %10.3f %10.3f\n' Cycles "$n" "$s" "$RW" "$RC"
        echo "cyc $n $s $RW $RC" >>runs.txt
    done
done

# --- noise --------------------------------------------------------------------------------
echo
echo "noise: RMS of (A - B) / REF / sqrt(2) over pixels with REF > $THRESHOLD max (G and luminance Y);"
echo "enoise: the same energy-weighted (sqrt(sum (A-B)^2 / 2 / sum REF^2)); flux: (A + B) / 2 / REF"
printf '%-10s %6s %9s %9s %9s %9s %9s %9s %9s\n' renderer spp noise_G "G*sqrtN" noise_Y "Y*sqrtN" \
    enoise_G "eG*sqrtN" flux_G
: >noise.txt
for r in neb cyc; do
    list=$NEB_SPP; label=nebrender
    [[ $r == cyc ]] && { list=$CYC_SPP; label=Cycles; }
    for n in $list; do
        noise "noise_${r}_$n" ref.exr "${r}_${n}_1.exr" "${r}_${n}_2.exr" >/dev/null
        ng=$(field "noise_${r}_$n" G noise); ny=$(field "noise_${r}_$n" Y noise)
        eg=$(field "noise_${r}_$n" G enoise); fg=$(field "noise_${r}_$n" G flux_ratio)
        awk -v l="$label" -v n="$n" -v g="$ng" -v y="$ny" -v e="$eg" -v f="$fg" 'BEGIN {
            printf "%-10s %6d %9.4f %9.3f %9.4f %9.3f %9.4f %9.3f %9.4f\n",
                   l, n, g, g * sqrt(n), y, y * sqrt(n), e, e * sqrt(n), f }'
        echo "$r $n $ng $ny $eg $fg" >>noise.txt
    done
done

# --- converged images alike? ---------------------------------------------------------------
echo
echo "converged images: mean of the two largest-N renders against the nebrender reference"
echo "(shape: RMS of (mean / flux - REF) / REF; shape_noise: what noise alone gives)"
NEB_TOP=${NEB_SPP##* }; CYC_TOP=${CYC_SPP##* }
noise shape_neb ref.exr "neb_${NEB_TOP}_1.exr" "neb_${NEB_TOP}_2.exr" --png neb_vs_ref.png >/dev/null
noise shape_cyc ref.exr "cyc_${CYC_TOP}_1.exr" "cyc_${CYC_TOP}_2.exr" --png cycles_vs_ref.png >/dev/null
printf '%-22s %8s %8s %8s %8s %8s %8s\n' "" flux_R flux_G flux_B flux_Y shape_Y shape_noise_Y
for x in "nebrender ${NEB_TOP}x2:shape_neb" "Cycles ${CYC_TOP}x2:shape_cyc"; do
    f=${x#*:}
    printf '%-22s %8.4f %8.4f %8.4f %8.4f %8.4f %8.4f\n' "${x%%:*}" "$(field "$f" R flux_ratio)" \
        "$(field "$f" G flux_ratio)" "$(field "$f" B flux_ratio)" "$(field "$f" Y flux_ratio)" \
        "$(field "$f" Y shape)" "$(field "$f" Y shape_noise)"
done
"$EXR_COMPARE" ref.exr "cyc_${CYC_TOP}_1.exr" --ratio-png cycles_ratio.png >cmp_cyc.txt
echo "exr_compare ref.exr cyc_${CYC_TOP}_1.exr (reads Blender's EXR; flux error = Cycles / nebrender - 1):"
sed 's/^/  /' cmp_cyc.txt

# --- Cycles step rate ----------------------------------------------------------------------
CHECK_LINE=""
if [[ $CHECK_STEP_RATE != 0 ]]; then
    echo
    echo "Cycles volume step rate $CHECK_STEP_RATE against $STEP_RATE: $CHECK_SPP spp, seed 1, both"
    if [[ " $CYC_SPP " == *" $CHECK_SPP "* ]]; then
        base=cyc_${CHECK_SPP}_1
        bw=$(awk -v n="$CHECK_SPP" '$1 == "cyc" && $2 == n && $3 == 1 { print $4 }' runs.txt)
        bc=$(awk -v n="$CHECK_SPP" '$1 == "cyc" && $2 == n && $3 == 1 { print $5 }' runs.txt)
    else
        base=cyc_check_base
        cyc "$base" "$CHECK_SPP" 1 "$STEP_RATE"; bw=$RW; bc=$RC
    fi
    cyc cyc_check "$CHECK_SPP" 1 "$CHECK_STEP_RATE"; kw=$RW; kc=$RC
    noise check_base ref.exr "$base.exr" "$base.exr" >/dev/null
    noise check_fine ref.exr cyc_check.exr cyc_check.exr >/dev/null
    noise check_diff cyc_check.exr "$base.exr" cyc_check.exr >/dev/null
    printf '  step rate %-5s render %8.3f s wall %8.3f s CPU, flux_Y %.4f\n' "$STEP_RATE" "$bw" "$bc" \
        "$(field check_base Y flux_ratio)"
    printf '  step rate %-5s render %8.3f s wall %8.3f s CPU, flux_Y %.4f\n' "$CHECK_STEP_RATE" "$kw" "$kc" \
        "$(field check_fine Y flux_ratio)"
    printf '  same seed: relative RMS difference (Y) %.4f; the noise of one render at %s spp: %s\n' \
        "$(awk -v x="$(field check_diff Y noise)" 'BEGIN { print x * sqrt(2) }')" "$CHECK_SPP" \
        "$(awk -v n="$CHECK_SPP" '$1 == "cyc" && $2 == n { print $4; f = 1 } END { if (!f) print "n/a" }' noise.txt)"
    CHECK_LINE=$(awk -v bc="$bc" -v kc="$kc" -v bw="$bw" -v kw="$kw" -v r="$CHECK_STEP_RATE" 'BEGIN {
        printf "at step rate %s Cycles is %.1fx slower (CPU), %.1fx (wall)", r, kc / bc, kw / bw }')
    echo "  $CHECK_LINE"
fi

# --- fit and verdict -----------------------------------------------------------------------
echo
awk -v target="$TARGET" -v res="$RES" '
FNR == NR { r = $1; k = ++nr[r]; N[r, k] = $2; W[r, k] = $4; C[r, k] = $5; next }
{ r = $1; k = ++nn[r]; NN[r, k] = $2; ng[r, k] = $3; ny[r, k] = $4; ne[r, k] = $5 }
function lsq(r, T,    i, sn, st, snn, snt, n, b) {   # slope of T against N
    n = nr[r]; sn = st = snn = snt = 0
    for (i = 1; i <= n; ++i) { sn += N[r, i]; st += T[r, i]; snn += N[r, i] ^ 2; snt += N[r, i] * T[r, i] }
    b = (n * snt - sn * st) / (n * snn - sn * sn)
    icpt[r] = (st - b * sn) / n
    return b
}
function cfit(r, X,    i, s) {   # c = geometric mean of noise * sqrt(N)
    s = 0
    for (i = 1; i <= nn[r]; ++i) s += log(X[r, i] * sqrt(NN[r, i]))
    return exp(s / nn[r])
}
function slope(r, X,    i, n, sx, sy, sxx, sxy, x, y, b) {   # d log noise / d log N
    n = nn[r]; sx = sy = sxx = sxy = 0
    for (i = 1; i <= n; ++i) { x = log(NN[r, i]); y = log(X[r, i]); sx += x; sy += y; sxx += x * x; sxy += x * y }
    b = (n * sxy - sx * sy) / (n * sxx - sx * sx)
    lc = (sy - b * sx) / n   # log noise = lc + b log N
    return b
}
END {
    name["neb"] = "nebrender"; name["cyc"] = "Cycles"; ord[1] = "neb"; ord[2] = "cyc"
    for (j = 1; j <= 2; ++j) {
        r = ord[j]
        bw[r] = lsq(r, W); aw[r] = icpt[r]
        bc[r] = lsq(r, C); ac[r] = icpt[r]
        cg[r] = cfit(r, ng); cy[r] = cfit(r, ny); ce[r] = cfit(r, ne)
        sg[r] = slope(r, ng); Sfree[r] = (sg[r] < -0.05 ? exp((log(target) - lc) / sg[r]) : 0)
        Stop[r] = NN[r, nn[r]] * (ng[r, nn[r]] / target) ^ 2
        sy[r] = slope(r, ny)
    }
    printf "fit (%s): noise = c / sqrt(N); time = a + b N (least squares over the runs)\n", res
    printf "%-10s %8s %8s %8s %8s %8s %11s %11s %9s %9s\n", "renderer", "c_G", "slope_G", "c_Y", "slope_Y",
           "c_eG", "b wall [s]", "b CPU [s]", "a wall", "a CPU"
    for (j = 1; j <= 2; ++j) {
        r = ord[j]
        printf "%-10s %8.3f %8.3f %8.3f %8.3f %8.3f %11.5f %11.5f %9.3f %9.3f\n", name[r], cg[r], sg[r],
               cy[r], sy[r], ce[r], bw[r], bc[r], aw[r], ac[r]
    }
    printf "\nto reach noise %.3g (per-sample cost only, b N; with the setup a in brackets):\n", target
    printf "%-22s %10s %12s %12s %12s %12s\n", "metric", "renderer", "samples", "wall [s]", "CPU [s]", "(a+bN) wall"
    m[1] = "G (per channel)"; m[2] = "Y (luminance)"; m[3] = "G energy-weighted"
    for (i = 1; i <= 3; ++i) {
        for (j = 1; j <= 2; ++j) {
            r = ord[j]
            c = (i == 1 ? cg[r] : i == 2 ? cy[r] : ce[r])
            S[r] = (c / target) ^ 2
            printf "%-22s %10s %12.0f %12.2f %12.2f %12.2f\n", m[i], name[r], S[r], bw[r] * S[r],
                   bc[r] * S[r], aw[r] + bw[r] * S[r]
        }
        printf "%-22s %10s %12s %12.2fx %11.2fx %11.2fx\n", "", "Cycles/neb", "", bw["cyc"] * S["cyc"] / (bw["neb"] * S["neb"]),
               bc["cyc"] * S["cyc"] / (bc["neb"] * S["neb"]),
               (aw["cyc"] + bw["cyc"] * S["cyc"]) / (aw["neb"] + bw["neb"] * S["neb"])
        ratio[i] = bc["cyc"] * S["cyc"] / (bc["neb"] * S["neb"])
    }
    if (Sfree["neb"] == 0 || Sfree["cyc"] == 0) print "G, free power law: n/a (noise does not fall with N)"
    else {
    printf "%-22s %10s %12.0f %12.2f %12.2f %12.2f\n", "G, free power law", name["neb"], Sfree["neb"],
           bw["neb"] * Sfree["neb"], bc["neb"] * Sfree["neb"], aw["neb"] + bw["neb"] * Sfree["neb"]
    printf "%-22s %10s %12.0f %12.2f %12.2f %12.2f\n", "(noise = c N^slope)", name["cyc"], Sfree["cyc"],
           bw["cyc"] * Sfree["cyc"], bc["cyc"] * Sfree["cyc"], aw["cyc"] + bw["cyc"] * Sfree["cyc"]
    printf "%-22s %10s %12s %12.2fx %11.2fx %11.2fx\n", "", "Cycles/neb", "",
           bw["cyc"] * Sfree["cyc"] / (bw["neb"] * Sfree["neb"]), bc["cyc"] * Sfree["cyc"] / (bc["neb"] * Sfree["neb"]),
           (aw["cyc"] + bw["cyc"] * Sfree["cyc"]) / (aw["neb"] + bw["neb"] * Sfree["neb"])
    }
    printf "%-22s %10s %12.0f %12.2f %12.2f %12.2f\n", "G, from largest N", name["neb"], Stop["neb"],
           bw["neb"] * Stop["neb"], bc["neb"] * Stop["neb"], aw["neb"] + bw["neb"] * Stop["neb"]
    printf "%-22s %10s %12.0f %12.2f %12.2f %12.2f\n", "(N_top (n/target)^2)", name["cyc"], Stop["cyc"],
           bw["cyc"] * Stop["cyc"], bc["cyc"] * Stop["cyc"], aw["cyc"] + bw["cyc"] * Stop["cyc"]
    printf "%-22s %10s %12s %12.2fx %11.2fx %11.2fx\n", "", "Cycles/neb", "",
           bw["cyc"] * Stop["cyc"] / (bw["neb"] * Stop["neb"]), bc["cyc"] * Stop["cyc"] / (bc["neb"] * Stop["neb"]),
           (aw["cyc"] + bw["cyc"] * Stop["cyc"]) / (aw["neb"] + bw["neb"] * Stop["neb"])
    printf "\nverdict (G, per channel, CPU time): Cycles needs %.2fx nebrender'"'"'s time to noise %.3g -> nebrender %s\n",
           ratio[1], target, (ratio[1] >= 1 ? "at least as fast: MET" : "slower: NOT MET")
}' runs.txt noise.txt

if [[ -n ${OUTDIR:-} ]]; then
    cp neb_vs_ref.png cycles_vs_ref.png cycles_ratio.png "$OUTDIR"/
    echo "PNGs (REF | A | B luminance; exr_compare ratio map) in $OUTDIR"
fi
echo "total run time $(( $(date +%s) - START )) s; load average now $(cut -d' ' -f1-3 /proc/loadavg)"
