#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Renders the README's examples, every nebgen preset, every camera, every integrator, the FITS
# outputs, nebscatter's fields (RGB and spectral) and a cube's round trip through nebexport and
# nebimport (.npy, .fits, .h5) with two builds of nebula, and checks that every grid, image,
# FITS file, cube and SED is the same, bit for bit (apart from file UUIDs, nebula:version and
# nebula:history; FITS: HISTORY, DATE, ORIGIN, CHECKSUM): the check that a refactoring changed
# no result. The .h5 cubes are compared through nebimport (the grids read back from them), not
# as bytes: HDF5 stamps each object with the time it was written.
#
#   bench/before_after.sh BEFORE_BUILD AFTER_BUILD [WORK]
#
# BEFORE_BUILD, AFTER_BUILD: CMake build folders (with tools/<tool>), e.g. a build of the
# previous commit (git worktree add /tmp/before HEAD~1; cmake -S /tmp/before -B /tmp/before/build;
# cmake --build /tmp/before/build -j2) and build. AFTER_BUILD must also have bench/same_output
# (or SAME_OUTPUT=path/to/same_output in the environment: the comparer of another build).
# Both builds run the same command lines (the tools are found on PATH), so nebula:command
# matches. Prints one line per output and exits 1 if any differs.
set -euo pipefail
SCRIPT=before_after
[[ $# -ge 2 ]] || { echo "usage: bench/before_after.sh BEFORE_BUILD AFTER_BUILD [WORK]" >&2; exit 2; }
before=$(cd "$1" && pwd)
after=$(cd "$2" && pwd)
work=${3:-$(mktemp -d)}
compare=${SAME_OUTPUT:-$after/bench/same_output}
[[ -x $compare ]] || { echo "$SCRIPT: error: $compare not found (cmake --build $2 --target same_output, or set SAME_OUTPUT)" >&2; exit 1; }

examples() {
    nebgen --res 64 --seed 1 -o nebula.vdb
    nebillum -i nebula.vdb -o lit.vdb
    nebpyramid -i lit.vdb --levels 3 -o pyramid.vdb
    nebphase -i nebula.vdb --t-count 16 --mu-bins 64 --error 0.03 -o phase.vdb
    nebrender -i pyramid.vdb --phase phase.vdb --levels 3 --res 128x128 -o nebula.exr --png nebula.png
    nebrender -i lit.vdb --res 128x128 -o single.exr --png single.png
    nebrender -i lit.vdb --integrator path --spp 4 --res 48x48 -o path.exr --png path.png
    nebgen --res 48 --seed 3 -o - | nebillum -i - -o - | nebpyramid -i - --levels 2 -o pipe.vdb
    nebgen --res 64 --seed 1 --spectral --expansion 25 --turbulence 8 --oiii 0.6 -o spectral.vdb
    nebillum -i spectral.vdb -o spectral-lit.vdb
    nebrender -i spectral-lit.vdb --spectral --res 96x96 --spectral-layers 8 -o spectral.exr --png spectral.png
    nebgen --res 48 --spectral --rotation 40 --emission-shape shell --emission 2 --density 150 \
        --lines '[O III]5007:1,[O III]4959:0.336,H-beta:0.3' -o shell.vdb
    nebillum -i shell.vdb -o shell-lit.vdb
    nebrender -i shell-lit.vdb --spectral --exaggerate-velocity 500 --eye 0,0,-19 --fov 30 \
        --res 96x96 -o doppler.exr --png doppler.png
}

# Every preset (nebgen --preset's list), small.
presets() {
    for preset in fbm box reflection external pillars bubble globule bipolar; do
        nebgen --preset "$preset" --res 32 -o "preset-$preset.vdb"
    done
}

# Every camera model on one small lit nebula (the fast integrator).
cameras() {
    nebgen --res 32 --seed 2 -o small.vdb
    nebillum -i small.vdb -o small-lit.vdb
    nebrender -i small-lit.vdb --res 48x32 -o cam-perspective.exr
    nebrender -i small-lit.vdb --camera fisheye --fov 200 --eye 0,0,-3 --res 48x48 -o cam-fisheye.exr
    nebrender -i small-lit.vdb --camera fisheye --dome-tilt 30 --roll 10 --eye 0,0,-3 --res 48x48 \
        -o cam-dome.exr
    nebrender -i small-lit.vdb --camera equirect --eye 0,0,-3 --res 64x32 -o cam-equirect.exr
    nebrender -i small-lit.vdb --camera orthographic --pixel-size 0.25 --res 48x40 -o cam-ortho.exr
    nebrender -i small-lit.vdb --camera orthographic --pixel-size 2arcsec --distance 400 \
        --res 40x40 -o cam-ortho-arcsec.exr
    nebrender -i small-lit.vdb --camera ods --ipd 0.3 --eye 0,0,-3 --res 64x64 -o cam-ods.exr
    # TODO(stereo fisheye, issue 44): once nebrender has it, uncomment (the option as added):
    # nebrender -i small-lit.vdb --camera fisheye --stereo --ipd 0.3 --eye 0,0,-3 --res 48x96 \
    #     -o cam-fisheye-stereo.exr
}

# Every integrator: fast (above), path, spectral (piecewise linear), spectral bands.
integrators() {
    nebrender -i small-lit.vdb --integrator path --spp 2 --res 32x32 -o int-path.exr
    nebgen --res 32 --seed 4 --spectral --expansion 25 --oiii 0.6 -o small-spectral.vdb
    nebillum -i small-spectral.vdb -o small-spectral-lit.vdb
    nebrender -i small-spectral-lit.vdb --spectral --spectral-layers 4 --res 32x32 \
        -o int-spectral.exr
    nebrender -i small-spectral-lit.vdb --bands 12 --res 32x32 -o int-bands.exr
}

# nebrender --fits: both layouts in RGB mode (one with the SED), a filter, and spectral.
fits_outputs() {
    nebrender -i small-lit.vdb --camera orthographic --res 32x32 -o fits-planes.exr \
        --fits fits-planes.fits --sed fits-planes.csv
    nebrender -i small-lit.vdb --camera orthographic --res 32x32 -o fits-tab.exr \
        --fits fits-tab.fits --fits-layout tab
    nebrender -i small-lit.vdb --sky 83.8,-5.4 --position-angle 20 --filter V --res 32x32 \
        -o fits-sky.exr --fits fits-sky.fits
    nebrender -i small-spectral-lit.vdb --spectral --spectral-layers 6 --camera orthographic \
        --res 32x32 -o fits-spectral.exr --fits fits-spectral.fits
}

# nebscatter's field (RGB and spectral), small, and renders through it.
scatter_fields() {
    nebscatter -i small-lit.vdb --packets 3000 -o scatter.vdb
    nebrender -i scatter.vdb --res 32x32 -o scatter.exr
    nebscatter -i small-spectral-lit.vdb --spectral 4 --packets 3000 -o scatter-spectral.vdb
    nebrender -i scatter-spectral.vdb --spectral --res 32x32 -o scatter-spectral.exr
}

# A cube out through nebexport and back in through nebimport, in each format.
cube_round_trips() {
    for ext in npy fits h5; do
        nebexport -i small.vdb -o "cube.$ext"
    done
    nebimport -i cube.fits -o cube-fits.vdb
    nebimport -i cube.h5 -o cube-h5.vdb
    nebimport -i cube.npy --unit cm-3 --voxel-size 0.3125pc -o cube-npy.vdb
}

run_all() {
    examples
    presets
    cameras
    integrators
    fits_outputs
    scatter_fields
    cube_round_trips
}

# Each side in a subshell with -e of its own (a subshell tested by || or if would ignore it, and
# a failing command in the middle would go unnoticed).
for side in before after; do
    build=${!side}
    rm -rf "${work:?}/$side" # no file of an earlier run compared
    mkdir -p "$work/$side"
    set +e
    (
        set -e
        cd "$work/$side"
        export PATH="$build/tools:$PATH"
        run_all
    ) 2> "$work/$side/stderr.log"
    rc=$?
    set -e
    [[ $rc -eq 0 ]] || { echo "$SCRIPT: error: the examples failed with the $side build; see $work/$side/stderr.log" >&2; exit 1; }
done

shopt -s nullglob
status=0 count=0
for f in "$work"/before/*.{vdb,exr,png,fits,csv,npy}; do
    name=$(basename "$f")
    count=$((count + 1))
    (cd "$work" && "$compare" "before/$name" "after/$name") || status=1
done
echo "$SCRIPT: $count outputs compared, $([[ $status -eq 0 ]] && echo "all the same" || echo "some differ")"
exit $status
