#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# What nebrender --fits (and --sed) adds to a render: the same orthographic view of a lit
# nebula with a per-star field rendered with and without the calibrated outputs, alternating,
# RUNS times each, wall time and peak RSS from /usr/bin/time -v. The --fits render is
# monochromatic with component layers (three more image layers) and writes the FITS file.
#
#   bench/fits_cost.sh FIELD.vdb [RES] [RUNS]     (e.g. a nebscatter --per-star output)
#   EXTRA=--spectral bench/fits_cost.sh SPECTRAL-FIELD.vdb [RES] [RUNS]
#
# EXTRA: options for both renders. With --spectral the --fits render also computes 47
# spectral layers and their four components (235 channels) and writes them as six cubes.
set -euo pipefail
[[ $# -ge 1 ]] || { echo "usage: $0 FIELD.vdb [RES] [RUNS]" >&2; exit 2; }
in=$1 res=${2:-512} runs=${3:-3}
here=$(cd "$(dirname "$0")/.." && pwd)
tools=${TOOLS:-$here/build/tools}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
view=(--camera orthographic --eye 0,0,-30 --distance 400 --res "${res}x${res}" --png none -v)
# shellcheck disable=SC2206 # EXTRA is a list of options
view+=(${EXTRA:-})
measure() { # label, args...
    local label=$1
    shift
    /usr/bin/time -v "$tools/nebrender" -i "$in" "${view[@]}" "$@" 2> "$work/time.txt"
    local wall rss render
    wall=$(grep "Elapsed (wall" "$work/time.txt" | awk '{print $NF}')
    rss=$(grep "Maximum resident" "$work/time.txt" | awk '{print $NF}')
    render=$(grep -oE "render [0-9.]+ s" "$work/time.txt" | head -1)
    echo "$label: $render (the integrator), wall $wall (all), peak RSS $((rss / 1024)) MiB"
}
for ((i = 1; i <= runs; ++i)); do
    measure "plain      " -o "$work/a.exr"
    measure "--fits --sed" -o "$work/b.exr" --fits "$work/b.fits" --sed "$work/b.csv" --sky 83.8,-5.4
done
