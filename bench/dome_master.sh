#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Time and peak memory of a planetarium dome master: the tilted fisheye of docs/cameras.md
# from inside the example nebula, at each size asked, with and without the level of detail.
#
# Usage: bench/dome_master.sh SCATTERED.vdb [SIZE...]   (default sizes: 4096; 8192 when asked)
# Environment: TOOLS (default build/tools), LODS (default "2 0": --lod values to run),
#              KEEP=1 keeps the temp dir (the EXRs and PNGs).
# SCATTERED.vdb: nebscatter's output of the example (bench/scale.sh with KEEP=1 leaves one
# per resolution, rRES/scattered.vdb). Prints one row per size and --lod: wall and CPU time
# [s], peak RSS [MiB], and the render's wall time per megapixel.
set -euo pipefail

TOOLS=${TOOLS:-build/tools}
LODS=${LODS:-2 0}
SCRIPT=dome_master
# shellcheck source=bench/common.sh
source "$(dirname "$0")/common.sh"
(($#)) || { echo "usage: bench/dome_master.sh SCATTERED.vdb [SIZE...]" >&2; exit 2; }
INPUT=$(realpath "$1")
shift
SIZES=("$@")
((${#SIZES[@]})) || SIZES=(4096)
for s in "${SIZES[@]}"; do
    [[ $s =~ ^[0-9]+$ && $s -ge 16 ]] || { echo "$SCRIPT: error: size '$s' is not a whole number >= 16" >&2; exit 2; }
done
[[ -r $INPUT ]] || { echo "$SCRIPT: error: cannot read $INPUT" >&2; exit 2; }
bench_require "$TIME" "$TOOLS/nebrender"
TOOLS=$(cd "$TOOLS" && pwd)
bench_tmpdir

echo "machine: $(nproc) cores, $(awk '/MemTotal/ { printf "%.1f GiB", $2 / 1048576 }' /proc/meminfo); load average $(cut -d' ' -f1-3 /proc/loadavg)"
printf "%-6s %5s %9s %9s %10s %12s\n" size lod wall_s cpu_s peak_MiB wall_s/Mpix
for size in "${SIZES[@]}"; do
    for lod in $LODS; do
        name="dome$size-lod$lod"
        timed "$name" "$TOOLS/nebrender" -i "$INPUT" --camera fisheye --dome-tilt 25 \
            --eye 0.5,0.5,-2 --res "${size}x$size" --lod "$lod" -v -o "$name.exr"
        printf "%-6s %5s %9.1f %9.1f %10.0f %12.2f\n" "$size" "$lod" "$(wall "$name")" \
            "$(cpu "$name")" "$(awk -v k="$(maxrss "$name")" 'BEGIN { print k / 1024 }')" \
            "$(awk -v w="$(wall "$name")" -v s="$size" 'BEGIN { print w / (s * s / 1e6) }')"
        grep -E "scene .* render" "$name.log" | sed 's/^/       /'
    done
done
