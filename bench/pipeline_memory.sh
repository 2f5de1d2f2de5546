#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Peak memory (maximum resident set size) and time of each stage of the example pipeline
#     nebgen --res RES -o n.vdb && nebillum -i n.vdb -o lit.vdb && nebrender -i lit.vdb ...
# at 256^3 (the README's nebula, its two stars), each stage a separate process reading and
# writing files, measured with /usr/bin/time -v.
#
# Usage: bench/pipeline_memory.sh [TOOLS_DIR]      (default: build/tools)
# Environment: RES (voxels per axis, default 256), IMAGE (default 512x512),
#              THREADS (--threads, default 0 = all cores), KEEP=1 keeps the temp dir.
set -euo pipefail

TOOLS=${1:-build/tools}
RES=${RES:-256}
IMAGE=${IMAGE:-512x512}
THREADS=${THREADS:-0}
SCRIPT=pipeline_memory
# shellcheck source=bench/common.sh
source "$(dirname "$0")/common.sh"
bench_require "$TIME" "$TOOLS/nebgen" "$TOOLS/nebillum" "$TOOLS/nebrender"
TOOLS=$(cd "$TOOLS" && pwd)
bench_tmpdir

row() {
    local name=$1 cmd=$2 out=$3
    printf "%-10s %9.2f %9.2f %12.1f %11.1f   %s\n" "$name" "$(wall "$name")" "$(cpu "$name")" \
        "$(awk -v k="$(maxrss "$name")" 'BEGIN { print k / 1024 }')" \
        "$(awk -v b="$(stat -c %s "$out")" 'BEGIN { print b / 1048576 }')" "$cmd"
}

echo "machine: $(nproc) cores, $(awk '/MemTotal/ { printf "%.1f GiB", $2 / 1048576 }' /proc/meminfo); load average $(cut -d' ' -f1-3 /proc/loadavg)"
timed nebgen "$TOOLS/nebgen" --res "$RES" --threads "$THREADS" -v -o n.vdb
timed nebillum "$TOOLS/nebillum" -i n.vdb -o lit.vdb --threads "$THREADS" -v
timed nebrender "$TOOLS/nebrender" -i lit.vdb --res "$IMAGE" --threads "$THREADS" -v -o f.exr

echo
printf "%-10s %9s %9s %12s %11s   %s\n" stage "wall [s]" "CPU [s]" "max RSS [MB]" "output [MB]" command
row nebgen "nebgen --res $RES -o n.vdb" n.vdb
row nebillum "nebillum -i n.vdb -o lit.vdb" lit.vdb
row nebrender "nebrender -i lit.vdb --res $IMAGE -o f.exr" f.exr
echo
echo "load average at the end: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "stage reports (-v):"
sed 's/^/  /' nebgen.log nebillum.log nebrender.log | grep -v '^\s*$' | grep -v $'\r' || true
