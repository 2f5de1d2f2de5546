#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Regenerates the gallery of docs/presets.md: for each nebgen preset, the render (single
# scattering plus nebscatter's field; gas emission where the preset has gas) as
# examples/presets/<preset>.png, and its statistics (nebstats --json) at 128^3 and 256^3 as
# examples/presets/<preset>-<res>.json, from which bench/preset_table.py writes the table.
# Needs the build (make -f Makefile.data build). Usage: examples/preset_gallery.sh [WORKDIR]
# Set PRESETS="reflection pillars" for some only.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
bin=${NEBULA_BUILD:-$root/build}/tools
work=${1:-$(mktemp -d)}
mkdir -p "$work" "$here/presets"
cd "$work"

for preset in ${PRESETS:-reflection external pillars bubble hii globule bipolar}; do
    # The picture: 128^3, as make -f Makefile.data PRESET=<preset> renders it (the presets
    # whose glow is ionised gas pass through nebionize, and their lines are raised by 40
    # beside the O stars' light: Makefile.data's EMISSION_SCALE).
    "$bin/nebgen" --preset "$preset" --res 128 -o "$preset.vdb" -q
    scale=1
    case $preset in
    pillars | bubble | hii)
        "$bin/nebionize" -i "$preset.vdb" -o "$preset-ionised.vdb" -q
        mv "$preset-ionised.vdb" "$preset.vdb"
        scale=40
        ;;
    esac
    "$bin/nebillum" -i "$preset.vdb" -o "$preset-lit.vdb" -q
    "$bin/nebscatter" -i "$preset-lit.vdb" -o "$preset-scattered.vdb" -q
    "$bin/nebrender" -i "$preset-scattered.vdb" --res 512x512 --gamma 0.6 -q \
        --emission-scale "$scale" -o "$preset.exr" --png "$here/presets/$preset.png"
    # The statistics, projected along z (the default camera's line of sight, nearly).
    for res in 128 256; do
        "$bin/nebgen" --preset "$preset" --res "$res" -o "$preset-$res.vdb" -q
        "$bin/nebstats" -i "$preset-$res.vdb" --json > "$here/presets/$preset-$res.json"
        rm -f "$preset-$res.vdb"
    done
done
python3 "$root/bench/preset_table.py" "$here/presets"
