#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Time and peak memory of every stage of the example pipeline, at each resolution asked:
#     nebgen --res RES -> nebillum -> nebscatter -> nebrender IMAGE
# plus the fixed cost of one frame (a 32x18 render of scattered.vdb: reading the file and
# building the scene, what every frame of a fly-through pays when each frame is its own
# process, as on a render farm). Each stage is a separate process reading and writing files,
# measured with /usr/bin/time -v; the tools' defaults otherwise (the example's).
#
# Usage: bench/scale.sh [RES...]      (default: 128 256 512; 1024 when asked)
# Environment: TOOLS (default build/tools), IMAGE (default 512x512), THREADS (--threads,
#              default 0 = all cores), KEEP=1 keeps the temp dir, NEBGEN_ARGS: more nebgen
#              options (e.g. NEBGEN_ARGS="--envelope 0.37": a cloud that fills less of its box,
#              to see memory follow the dust).
# Prints, per resolution, one row per stage: wall and CPU time [s], peak RSS [MiB], output
# size [MiB]; then the pipeline's total wall time and its largest peak.
set -euo pipefail

TOOLS=${TOOLS:-build/tools}
IMAGE=${IMAGE:-512x512}
THREADS=${THREADS:-0}
SCRIPT=scale
# shellcheck source=bench/common.sh
source "$(dirname "$0")/common.sh"
RESES=("$@")
((${#RESES[@]})) || RESES=(128 256 512)
for r in "${RESES[@]}"; do
    [[ $r =~ ^[0-9]+$ && $r -ge 8 ]] || { echo "$SCRIPT: error: resolution '$r' is not a whole number >= 8" >&2; exit 2; }
done
bench_require "$TIME" "$TOOLS/nebgen" "$TOOLS/nebillum" "$TOOLS/nebscatter" "$TOOLS/nebrender"
TOOLS=$(cd "$TOOLS" && pwd)
bench_tmpdir

row() { # name output command
    local name=$1 out=$2 cmd=$3
    printf "%-12s %9.2f %9.2f %10.0f %10.1f   %s\n" "$name" "$(wall "$name")" "$(cpu "$name")" \
        "$(awk -v k="$(maxrss "$name")" 'BEGIN { print k / 1024 }')" \
        "$(awk -v b="$(stat -c %s "$out")" 'BEGIN { print b / 1048576 }')" "$cmd"
}

echo "machine: $(nproc) cores, $(awk '/MemTotal/ { printf "%.1f GiB", $2 / 1048576 }' /proc/meminfo); load average $(cut -d' ' -f1-3 /proc/loadavg)"
for res in "${RESES[@]}"; do
    mkdir -p "r$res" && cd "r$res"
    # shellcheck disable=SC2086 # NEBGEN_ARGS is a list of options
    timed nebgen "$TOOLS/nebgen" --res "$res" ${NEBGEN_ARGS:-} --threads "$THREADS" -v -o n.vdb
    timed nebillum "$TOOLS/nebillum" -i n.vdb --threads "$THREADS" -v -o lit.vdb
    timed nebscatter "$TOOLS/nebscatter" -i lit.vdb --threads "$THREADS" -v -o scattered.vdb
    timed nebrender "$TOOLS/nebrender" -i scattered.vdb --res "$IMAGE" --threads "$THREADS" -v \
        -o f.exr
    timed frame-fixed "$TOOLS/nebrender" -i scattered.vdb --res 32x18 --threads "$THREADS" -v \
        -o fixed.exr
    echo
    echo "== ${res}^3 (load average $(cut -d' ' -f1-3 /proc/loadavg))"
    printf "%-12s %9s %9s %10s %10s   %s\n" stage "wall [s]" "CPU [s]" "peak [MiB]" "out [MiB]" command
    row nebgen n.vdb "nebgen --res $res ${NEBGEN_ARGS:+$NEBGEN_ARGS }-o n.vdb"
    row nebillum lit.vdb "nebillum -i n.vdb -o lit.vdb"
    row nebscatter scattered.vdb "nebscatter -i lit.vdb -o scattered.vdb"
    row nebrender f.exr "nebrender -i scattered.vdb --res $IMAGE -o f.exr"
    row frame-fixed fixed.exr "nebrender -i scattered.vdb --res 32x18 -o fixed.exr"
    total=0 peak=0
    for s in nebgen nebillum nebscatter nebrender; do
        total=$(awk -v a="$total" -v b="$(wall "$s")" 'BEGIN { print a + b }')
        peak=$(awk -v a="$peak" -v b="$(maxrss "$s")" 'BEGIN { print (b > a ? b : a) }')
    done
    printf "pipeline     %9.2f %9s %10.0f\n" "$total" "" "$(awk -v k="$peak" 'BEGIN { print k / 1024 }')"
    grep -h "scene .* s, render" frame-fixed.log | sed 's/^/  frame-fixed: /' || true
    grep -h "scene fields:" nebrender.log | sed 's/^/  /' || true
    cd ..
done
