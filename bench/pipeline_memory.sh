#!/usr/bin/env bash
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
TIME=/usr/bin/time

[[ -x $TIME ]] || { echo "pipeline_memory: error: $TIME missing (apt-get install -y time)" >&2; exit 1; }
for t in nebgen nebillum nebrender; do
    [[ -x $TOOLS/$t ]] || { echo "pipeline_memory: error: $TOOLS/$t not found or not executable" >&2; exit 1; }
done
TOOLS=$(cd "$TOOLS" && pwd)

TMP=$(mktemp -d "${TMPDIR:-/tmp}/nebula-mem.XXXXXX")
cleanup() { if [[ ${KEEP:-0} == 1 ]]; then echo "kept $TMP" >&2; else rm -rf "$TMP"; fi; }
trap cleanup EXIT
cd "$TMP"

# stage NAME CMD...: runs CMD under /usr/bin/time -v (report in NAME.time, output in NAME.log).
stage() {
    local name=$1; shift
    if ! "$TIME" -v -o "$name.time" "$@" >"$name.log" 2>&1; then
        echo "pipeline_memory: error: '$*' failed:" >&2
        cat "$name.log" >&2
        exit 1
    fi
}
field() { awk -F': ' -v k="$2" 'index($0, k) { print $2 }' "$1.time"; }
seconds() { field "$1" "Elapsed (wall clock)" | awk '{ n = split($1, p, ":"); s = 0;
                                                  for (i = 1; i <= n; ++i) s = s * 60 + p[i]; print s }'; }
row() {
    local name=$1 cmd=$2 out=$3
    local rss user sys size
    rss=$(field "$name" "Maximum resident set size")
    user=$(field "$name" "User time"); sys=$(field "$name" "System time")
    size=$(stat -c %s "$out")
    printf "%-10s %9.2f %9.2f %12.1f %11.1f   %s\n" "$name" "$(seconds "$name")" \
        "$(awk -v u="$user" -v s="$sys" 'BEGIN { print u + s }')" "$(awk -v k="$rss" 'BEGIN { print k / 1024 }')" \
        "$(awk -v b="$size" 'BEGIN { print b / 1048576 }')" "$cmd"
}

echo "machine: $(nproc) cores, $(awk '/MemTotal/ { printf "%.1f GiB", $2 / 1048576 }' /proc/meminfo); load average $(cut -d' ' -f1-3 /proc/loadavg)"
stage nebgen "$TOOLS/nebgen" --res "$RES" --threads "$THREADS" -v -o n.vdb
stage nebillum "$TOOLS/nebillum" -i n.vdb -o lit.vdb --threads "$THREADS" -v
stage nebrender "$TOOLS/nebrender" -i lit.vdb --res "$IMAGE" --threads "$THREADS" -v -o f.exr

echo
printf "%-10s %9s %9s %12s %11s   %s\n" stage "wall [s]" "CPU [s]" "max RSS [MB]" "output [MB]" command
row nebgen "nebgen --res $RES -o n.vdb" n.vdb
row nebillum "nebillum -i n.vdb -o lit.vdb" lit.vdb
row nebrender "nebrender -i lit.vdb --res $IMAGE -o f.exr" f.exr
echo
echo "load average at the end: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "stage reports (-v):"
sed 's/^/  /' nebgen.log nebillum.log nebrender.log | grep -v '^\s*$' | grep -v $'\r' || true
