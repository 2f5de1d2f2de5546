#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Regenerates the figures of docs/tools/nebphase.md, the effective phase function:
#   examples/phase.svg          Phi(t, theta) of the default dust for a few voxel thicknesses t
#   examples/phase-single.png   a thick nebula, single scattering (a p(mu))
#   examples/phase-table.png    the same with nebrender --phase (same exposure)
#   examples/phase-ratio.png    luminance ratio table / single (blue: darker, red: brighter)
# Needs the build (make -f Makefile.data build). Usage: examples/phase_figures.sh [WORKDIR]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
bin=$root/build/tools
work=${1:-$(mktemp -d)}
mkdir -p "$work"
cd "$work"

# The plot: the default table (64 t x 128 mu bins, albedo 0.6, g 0.6).
"$bin/nebphase" -o phase.vdb --json phase.json
python3 "$here/plot_phase.py" phase.json "$here/phase.svg" --t 0.0001,0.1,1,3,10,30

# A nebula whose voxels are optically thick: ten times the example's density at 64^3
# (voxel optical thickness up to ~3 in V).
"$bin/nebgen" --res 64 --density 40000 -o thick.vdb
"$bin/nebillum" -i thick.vdb -o thick-lit.vdb
common=(-i thick-lit.vdb --res 384x384 --exposure -3.8 --gamma 0.45)
"$bin/nebrender" "${common[@]}" -o single.exr --png "$here/phase-single.png"
"$bin/nebrender" "${common[@]}" --phase phase.vdb -o table.exr --png "$here/phase-table.png"
# Scattered light only (no star sprites) for the comparison.
"$bin/nebrender" "${common[@]}" --no-stars -o single-ns.exr --no-png
"$bin/nebrender" "${common[@]}" --no-stars --phase phase.vdb -o table-ns.exr --no-png
"$root/build/bench/exr_compare" single-ns.exr table-ns.exr --threshold 0.001 \
    --ratio-png "$here/phase-ratio.png"
