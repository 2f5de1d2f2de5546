#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Instructions each nebrender integrator spends on its pixels, counted by callgrind (the same
# count for the same binary and inputs, however busy the machine): the instructions of a
# render minus those of a 1x1 render of the same scene (reading, scene building, writing).
# With two builds, compare a change's kernels without the noise of timings.
#
#   bench/kernel_instructions.sh BUILD [BUILD2] [WORK]
#
# Makes a 64^3 example nebula, its levels and a quick phase table in WORK with the first
# build, then counts per integrator: fast (single scattering), fast with --phase and 3
# levels, spectral, path tracer.
set -euo pipefail
[[ $# -ge 1 ]] || { echo "usage: bench/kernel_instructions.sh BUILD [BUILD2] [WORK]" >&2; exit 2; }
builds=("$1")
[[ $# -ge 2 && -d $2/tools ]] && builds+=("$2")
work=${3:-$(mktemp -d)}
command -v valgrind >/dev/null || { echo "kernel_instructions: error: valgrind not found (apt-get install valgrind)" >&2; exit 1; }
mkdir -p "$work"
cd "$work"
t=$(cd "${builds[0]}/tools" && pwd)
[[ -f pyramid.vdb ]] || {
    "$t/nebgen" --res 64 --seed 1 -q -o nebula.vdb
    "$t/nebillum" -i nebula.vdb -q -o lit.vdb
    "$t/nebpyramid" -i lit.vdb --levels 3 -q -o pyramid.vdb
    "$t/nebphase" -i nebula.vdb --t-count 16 --mu-bins 64 --error 0.03 -q -o phase.vdb
    "$t/nebgen" --res 64 --seed 1 --spectral --expansion 25 --turbulence 8 --oiii 0.6 -q -o spectral.vdb
    "$t/nebillum" -i spectral.vdb -q -o spectral-lit.vdb
}
count() { valgrind --tool=callgrind --callgrind-out-file=/dev/null "$@" 2>&1 |
    sed -n 's/.*Collected : \([0-9]*\).*/\1/p'; }
printf '%-44s' "integrator (image)"
for b in "${builds[@]}"; do printf ' %16s' "$(basename "$(cd "$b" && pwd)")"; done
echo
while IFS='|' read -r name res args; do
    printf '%-44s' "$name ($res)"
    for b in "${builds[@]}"; do
        r=$(cd "$b/tools" && pwd)/nebrender
        full=$(count "$r" $args --res "$res" --threads 1 -q -o k.exr --no-png --no-stars)
        base=$(count "$r" $args --res 1x1 --threads 1 -q -o k.exr --no-png --no-stars)
        printf ' %16s' "$((full - base))"
    done
    echo
done <<'LIST'
fast, single scattering|64x64|-i lit.vdb
fast, --phase, 3 levels|64x64|-i pyramid.vdb --phase phase.vdb --levels 3
spectral, piecewise-linear|32x32|-i spectral-lit.vdb --spectral
path tracer, spp 2|24x24|-i lit.vdb --integrator path --spp 2
LIST
