#!/usr/bin/env bash
# Renders the README's examples with two builds of nebula and checks that every grid and image
# is the same, bit for bit (apart from file UUIDs, nebula:version and nebula:history): the check
# that a refactoring changed no result.
#
#   bench/before_after.sh BEFORE_BUILD AFTER_BUILD [WORK]
#
# BEFORE_BUILD, AFTER_BUILD: CMake build folders (with tools/<tool>), e.g. a build of the
# previous commit (git worktree add /tmp/before HEAD~1; cmake -S /tmp/before -B /tmp/before/build;
# cmake --build /tmp/before/build -j2) and build. AFTER_BUILD must also have bench/same_output.
# Both builds run the same command lines (the tools are found on PATH), so nebula:command
# matches. Prints one line per output and exits 1 if any differs.
set -euo pipefail
SCRIPT=before_after
[[ $# -ge 2 ]] || { echo "usage: bench/before_after.sh BEFORE_BUILD AFTER_BUILD [WORK]" >&2; exit 2; }
before=$(cd "$1" && pwd)
after=$(cd "$2" && pwd)
work=${3:-$(mktemp -d)}
compare=$after/bench/same_output
[[ -x $compare ]] || { echo "$SCRIPT: error: $compare not found (cmake --build $2 --target same_output)" >&2; exit 1; }

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
    # nebscatter's fields (summed, per star, spectral) and renders that read them back.
    nebscatter -i lit.vdb --packets 20000 --field-level 2 -o scattered.vdb
    nebscatter -i lit.vdb --packets 20000 --field-level 2 --per-star -o per-star.vdb
    nebscatter -i spectral-lit.vdb --packets 5000 --field-level 2 --spectral 6 -o spectral-field.vdb
    nebrender -i scattered.vdb --res 96x96 -o field.exr --png field.png
    nebrender -i per-star.vdb --camera orthographic --res 64x64 -o per-star.exr \
        --fits per-star.fits
    nebrender -i spectral-field.vdb --spectral --res 64x64 -o spectral-field.exr
}
export -f examples

for side in before after; do
    build=${!side}
    mkdir -p "$work/$side"
    # A shell of its own, so that -e stops at the first failing example (a subshell on the
    # left of || would run on after one).
    (
        cd "$work/$side"
        export PATH="$build/tools:$PATH"
        bash -eo pipefail -c examples 2> stderr.log
    ) || { echo "$SCRIPT: error: the examples failed with the $side build; see $work/$side/stderr.log" >&2; exit 1; }
done

status=0
for f in "$work"/before/*.vdb "$work"/before/*.exr "$work"/before/*.png "$work"/before/*.fits; do
    name=$(basename "$f")
    (cd "$work" && "$compare" "before/$name" "after/$name") || status=1
done
exit $status
