#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# nebgen's time and peak memory per preset at one resolution (default 512^3), with
# /usr/bin/time -v, the grids written to a temporary folder that is deleted afterwards.
# Target (docs/presets.md): nebgen --preset reflection --res 512 in at most 30 s on 2 cores.
#
#   bench/nebgen_presets.sh [BUILD] [RES] [PRESET...]   (defaults: build, 512, all six)
#   FBM=1 bench/nebgen_presets.sh ...                     also the seeds' fBm cloud (slow)
set -euo pipefail
build=${1:-build}
res=${2:-512}
shift $(( $# > 2 ? 2 : $# ))
presets=("${@:-reflection external pillars bubble globule bipolar}")
read -r -a presets <<< "${presets[*]}"
[[ ${FBM:-0} = 1 ]] && presets+=(fbm)
tool=$(cd "$build/tools" && pwd)/nebgen
[[ -x $tool ]] || { echo "no $tool: build nebgen first" >&2; exit 1; }
[[ -x /usr/bin/time ]] || { echo "needs /usr/bin/time (Debian: time)" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "nebgen at $res^3 on $(nproc) cores (load before: $(cut -d' ' -f1-3 /proc/loadavg))"
printf '%-12s %10s %12s %12s\n' preset "wall [s]" "peak [MiB]" "file [MiB]"
for preset in "${presets[@]}"; do
    /usr/bin/time -v "$tool" --preset "$preset" --res "$res" -q -o "$work/$preset.vdb" \
        2> "$work/time.txt"
    wall=$(awk -F': ' '/Elapsed/ {n = split($2, t, ":"); s = 0;
                                  for (i = 1; i <= n; ++i) s = s * 60 + t[i]; print s}' \
               "$work/time.txt")
    rss=$(awk -F': ' '/Maximum resident/ {printf "%.0f", $2 / 1024}' "$work/time.txt")
    size=$(du -m "$work/$preset.vdb" | cut -f1)
    printf '%-12s %10s %12s %12s\n' "$preset" "$wall" "$rss" "$size"
    rm -f "$work/$preset.vdb"
done
