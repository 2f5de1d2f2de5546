#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Regenerates the figures of docs/spectral.md (nebrender --spectral):
#   examples/spectral.png   the example nebula with spectral grids: RGB mode | spectral mode
#   examples/doppler.png    a rotating [O III] + H-beta shell: at rest | velocities x500
# Needs the build (make -f Makefile.data build). Usage: examples/spectral_figures.sh [WORKDIR]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
bin=${NEBULA_BUILD:-$root/build}/tools
work=${1:-$(mktemp -d)}
mkdir -p "$work"
cd "$work"

# The example nebula (same density and emission as make -f Makefile.data) with its spectral
# grids: gas expanding at 25 km/s from the B star with 8 km/s turbulence, an [O III] zone.
"$bin/nebgen" --spectral --expansion 25 --turbulence 8 --oiii 0.6 -o ex.vdb
"$bin/nebillum" -i ex.vdb -o ex-lit.vdb
"$bin/nebrender" -i ex-lit.vdb -o rgb.exr --png rgb.png
"$bin/nebrender" -i ex-lit.vdb --spectral -o spectral.exr --png spectral.png
python3 "$root/bench/tile_png.py" "$here/spectral.png" rgb.png spectral.png

# A rotating emission shell seen edge-on (rotation axis up): the side turning towards the
# eye is blue-shifted, the other red-shifted. 40 km/s at the shell, exaggerated 500 times.
"$bin/nebgen" --res 96 --spectral --rotation 40 --emission-shape shell --emission 2 \
    --density 150 --lines '[O III]5007:1,[O III]4959:0.336,H-beta:0.3' -o shell.vdb
"$bin/nebillum" -i shell.vdb -o shell-lit.vdb
view=(-i shell-lit.vdb --res 384x384 --eye 0,0,-19 --fov 30 --spectral)
"$bin/nebrender" "${view[@]}" -o rest.exr --png rest.png
"$bin/nebrender" "${view[@]}" --exaggerate-velocity 500 -o doppler.exr --png doppler.png
python3 "$root/bench/tile_png.py" "$here/doppler.png" rest.png doppler.png
