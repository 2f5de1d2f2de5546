#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# nebrender against OpenVDB's own vdb_render on the same view of the same density grid
# (the issue's speed target: nebrender at least 50x faster than vdb_render on the default
# nebula at 128^3, one star, 512x512; both measured here, side by side, in one run).
#
# Usage: bench/render_vs_vdb_render.sh [TOOLS_DIR]      (default: build/tools)
# Environment: REPEAT (runs of each renderer, median reported; default 3),
#              EYE, LOOK_AT, UP, FOV (the view; default 4,3,-19  0,0,0  0,1,0  36),
#              VDB_STEP, VDB_SHADOWSTEP (vdb_render's steps [voxels]; default 0.5 and 0.5),
#              VDB_RENDER (default /usr/bin/vdb_render), KEEP=1 keeps the temp dir.
#
# What is compared (and what is not the same):
#   * Same density grid (nebgen's default nebula at --res 128 with one star, its "alpha"),
#     same camera, given to both explicitly (EYE, LOOK_AT, UP, FOV; default nebrender's
#     default view; vdb_render's -fov is horizontal too: tan(fov/2) = aperture / (2 focal)),
#     512x512, same primary step (0.5 voxel), trilinear density lookups, all cores each.
#   * Same optical depths: vdb_render attenuates by exp(-(absorb + scatter) * density * step)
#     with the step in VOXELS (its VolumeRayIntersector marches the index-space ray), so
#     absorb + scatter = kappa_V * voxelSize, split as (1 - albedo) : albedo, with kappa_V
#     and albedo read from the file's nebula:dust. Grey (V band); nebrender uses the CCM
#     extinction per channel.
#   * Same transmittance cut-off: nebrender stops a ray when T < 1e-5 in every channel;
#     vdb_render when |T|^2 < cutoff, so cutoff = 3e-10 (its density cut-off, the same
#     number, then only skips n_H < 3e-10 cm^-3, i.e. nothing). -gain 0: plain Beer-Lambert
#     along the shadow ray.
#   * The light: vdb_render has only a DIRECTIONAL light; it is pointed from the cube's
#     centre towards the star. Every dusty primary sample marches a shadow ray towards it
#     (VDB_SHADOWSTEP voxels per step) to the volume's edge. nebrender instead reads tau_V
#     from nebillum's grid (exact point-star optical depths, computed once per voxel); so
#     the table also lists nebillum + nebrender against vdb_render.
set -euo pipefail

TOOLS=${1:-build/tools}
REPEAT=${REPEAT:-3}
VDB_STEP=${VDB_STEP:-0.5}
VDB_SHADOWSTEP=${VDB_SHADOWSTEP:-0.5}
VDB_RENDER=${VDB_RENDER:-/usr/bin/vdb_render}

RES=128          # voxels per axis
SIZE=10          # cube edge [pc] (nebgen's default)
STAR_POS=0.4,0.3,-0.2   # nebgen's example star alpha [pc]
EYE=${EYE:-4,3,-19}; LOOK_AT=${LOOK_AT:-0,0,0}; UP=${UP:-0,1,0}; FOV=${FOV:-36}

SCRIPT=render_vs_vdb_render
# shellcheck source=bench/common.sh
source "$(dirname "$0")/common.sh"
bench_require "$TOOLS/nebgen" "$TOOLS/nebillum" "$TOOLS/nebrender" "$VDB_RENDER" "$TIME" \
    /usr/bin/vdb_print
TOOLS=$(cd "$TOOLS" && pwd)
bench_tmpdir

median() { sort -g | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }

NPROC=$(nproc); export NPROC
echo "machine: $NPROC cores, $(uname -m); load average $(cut -d' ' -f1-3 /proc/loadavg)"
echo "scene: nebgen --res $RES, one star at $STAR_POS pc; 512x512 from $EYE to $LOOK_AT, fov $FOV; median of $REPEAT runs"

timed gen "$TOOLS/nebgen" --res "$RES" --size "$SIZE" --star "alpha:$STAR_POS:8000:B1V" -o n.vdb
timed illum "$TOOLS/nebillum" -i n.vdb -o lit.vdb

# nebrender: all cores, then 1 thread for the per-sample CPU cost.
VIEW=(--res 512x512 --eye "$EYE" --look-at "$LOOK_AT" --up "$UP" --fov "$FOV")
for r in $(seq "$REPEAT"); do
    timed "neb$r" "$TOOLS/nebrender" -i lit.vdb "${VIEW[@]}" --no-png -o f.exr -v
    timed "neb1t$r" "$TOOLS/nebrender" -i lit.vdb "${VIEW[@]}" --no-png -o f1.exr -v --threads 1
done
# -v line: "nebrender: scene S s, render R s, N rays, M samples (...)"
renderSec() { sed -n 's/.*render \([0-9.eE+-]*\) s.*/\1/p' "$1.log" | head -n1; }
samples()   { sed -n 's/.* \([0-9][0-9]*\) samples.*/\1/p' "$1.log" | head -n1; }
SAMPLES=$(samples neb1)
[[ -n $SAMPLES && -n $(renderSec neb1) ]] ||
    { echo "render_vs_vdb_render: error: no 'render ... s' / '... samples' in nebrender -v:" >&2;
      cat neb1.log >&2; exit 1; }
for r in $(seq "$REPEAT"); do
    [[ $(samples "neb$r") == "$SAMPLES" && $(samples "neb1t$r") == "$SAMPLES" ]] ||
        { echo "render_vs_vdb_render: error: sample counts differ between runs" >&2; exit 1; }
done

# vdb_render: the same grid, camera and optical depths (see the header).
# kappa_V [pc^-1 cm^3] and albedo from the file's nebula:dust JSON.
DUST=$(/usr/bin/vdb_print -m n.vdb | sed -n 's/^nebula:dust: //p')
dustField() { echo "$DUST" | grep -o "\"$1\": *[-0-9.eE+]*" | sed 's/.*: *//' || true; }
KAPPA_V=$(dustField kappa_V); ALBEDO=$(dustField albedo)
[[ -n $KAPPA_V && -n $ALBEDO ]] ||
    { echo "render_vs_vdb_render: error: no kappa_V/albedo in n.vdb's nebula:dust: '$DUST'" >&2; exit 1; }
VOXEL=$(awk -v s="$SIZE" -v n="$RES" 'BEGIN { printf "%.9g", s / n }')
ABSORB=$(awk -v k="$KAPPA_V" -v v="$VOXEL" -v a="$ALBEDO" 'BEGIN { printf "%.9g", k * v * (1 - a) }')
SCATTER=$(awk -v k="$KAPPA_V" -v v="$VOXEL" -v a="$ALBEDO" 'BEGIN { printf "%.9g", k * v * a }')
LIGHT=$(echo "$STAR_POS" | awk -F, '{ n = sqrt($1*$1 + $2*$2 + $3*$3);
                                      printf "%.6f,%.6f,%.6f", $1/n, $2/n, $3/n }')
VDB_ARGS=(n.vdb vdb.exr -name density -res 512x512 -camera persp
          -translate "$EYE" -lookat "$LOOK_AT" -up "$UP" -fov "$FOV"
          -light "$LIGHT,1,1,1" -absorb "$ABSORB,$ABSORB,$ABSORB"
          -scatter "$SCATTER,$SCATTER,$SCATTER" -step "$VDB_STEP" -shadowstep "$VDB_SHADOWSTEP"
          -gain 0 -cutoff 3e-10 -cpus 0 -v)
echo "dust: kappa_V $KAPPA_V pc^-1 cm^3, albedo $ALBEDO, voxel $VOXEL pc"
echo "vdb_render ${VDB_ARGS[*]}"
for r in $(seq "$REPEAT"); do
    timed "vdb$r" "$VDB_RENDER" "${VDB_ARGS[@]}"
done
# -v line after "ray-tracing density...": "vdb_render: ...completed in S sec"
vdbTrace() { awk '/ray-tracing/ { f = 1; next } f && /completed in/ {
                   for (i = 1; i <= NF; ++i) if ($i == "in") { print $(i + 1); exit } }' "$1.log"; }
[[ -n $(vdbTrace vdb1) ]] ||
    { echo "render_vs_vdb_render: error: no ray-tracing time in vdb_render -v:" >&2;
      cat vdb1.log >&2; exit 1; }

col() { local f=$1; shift; for r in $(seq "$REPEAT"); do "$f" "$@" "$r"; done | median; }
nebRender() { renderSec "neb$1"; }
neb1tRender() { renderSec "neb1t$1"; }
nebWall() { wall "neb$1"; }
nebCpu() { cpu "neb$1"; }
vdbTraceR() { vdbTrace "vdb$1"; }
vdbWall() { wall "vdb$1"; }
vdbCpu() { cpu "vdb$1"; }

NEB_R=$(col nebRender); NEB_R1=$(col neb1tRender); NEB_W=$(col nebWall); NEB_C=$(col nebCpu)
VDB_R=$(col vdbTraceR); VDB_W=$(col vdbWall); VDB_C=$(col vdbCpu)
ILL_W=$(wall illum); ILL_C=$(cpu illum)

echo
echo "load average at the end: $(cut -d' ' -f1-3 /proc/loadavg) (on a shared machine, trust the CPU columns)"
awk -v nr="$NEB_R" -v nr1="$NEB_R1" -v nw="$NEB_W" -v nc="$NEB_C" -v iw="$ILL_W" -v ic="$ILL_C" \
    -v vr="$VDB_R" -v vw="$VDB_W" -v vc="$VDB_C" -v ns="$SAMPLES" \
    -v nm="$(maxrss neb1)" -v im="$(maxrss illum)" -v vm="$(maxrss vdb1)" 'BEGIN {
    h = "%-38s %9s %9s %9s %9s %8s\n"
    f = "%-38s %9.3f %9.3f %9.1f %9.1f %8d\n"
    printf h, "tool (median of runs)", "wall [s]", "CPU [s]", "vdb/wall", "vdb/CPU", "RSS [MB]"
    printf f, "vdb_render, ray-tracing (-v) [1]",      vr, vc, 1, 1, vm / 1024
    printf f, "vdb_render, whole process",             vw, vc, 1, 1, vm / 1024
    printf f, "nebrender, render (-v) [2]",            nr, nr1, vr / nr, vc / nr1, nm / 1024
    printf f, "nebrender, whole process",              nw, nc, vw / nw, vc / nc, nm / 1024
    printf f, "nebillum + nebrender, whole processes", iw + nw, ic + nc, vw / (iw + nw),
           vc / (ic + nc), (im > nm ? im : nm) / 1024
    printf "[1] CPU: the whole vdb_render process (reading and writing take ~0.02 s)\n"
    printf "[2] CPU: the render phase at --threads 1\n\n"
    printf "target: nebrender >= 50x faster than vdb_render (render phases, wall): %.1fx -> %s\n",
           vr / nr, (vr / nr >= 50 ? "MET" : "NOT MET")
    printf "nebrender samples (field lookups in occupied space): %d\n", ns
    printf "nebrender per sample: %.1f ns wall at %d threads; %.1f ns CPU (render at --threads 1); %.1f ns CPU (whole process incl. I/O)\n",
           1e9 * nr / ns, ENVIRON["NPROC"], 1e9 * nr1 / ns, 1e9 * nc / ns
}'
