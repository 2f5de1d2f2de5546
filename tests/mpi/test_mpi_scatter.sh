#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# nebscatter over MPI ranks (docs/tools/nebscatter.md, "nebscatter over MPI"), with OpenMPI's
# mpirun on this machine (--oversubscribe: more ranks than cores is fine for a test).
#
#   test_mpi_scatter.sh TOOLS_DIR WORK_DIR HAVE_MPI
#
# HAVE_MPI is the build's NEBULA_HAVE_MPI: anything but ON skips the test (exit 77, with a
# message). WORK_DIR is emptied and reused. Checks, on a 24^3 scene with two stars and
# emission:
#   - 1, 2 and 4 ranks, and one process of 1 or 2 threads, give grids with the same
#     checksums (the tallies are integers, summed exactly onto rank 0);
#   - only rank 0 writes: the 2-rank run's -v log has one "wrote" line;
#   - more ranks than packets: exit code 2 naming --packets and the ranks, nothing written;
#   - -i - (stdin reaches rank 0 only): exit code 2, nothing written;
#   - ranks started with another --packets, --seed or input file (same name, other folder):
#     refused before the work, naming what differs, nothing written; --threads and -v may
#     differ;
#   - a rank killed mid-run: the launcher fails, no output and no temporary is left.
# Exit 0 when every check passed, 1 otherwise, 77 skipped.
set -euo pipefail

[[ $# -eq 3 ]] || { echo "usage: $0 TOOLS_DIR WORK_DIR HAVE_MPI" >&2; exit 2; }
TOOLS=$1 WORK=$2 HAVE=$3
if [[ $HAVE != ON ]]; then
    echo "mpi_scatter: skipped: this build has no MPI (configure with libopenmpi-dev installed, NEBULA_WITH_MPI=AUTO or ON)"
    exit 77
fi
command -v mpirun >/dev/null || { echo "mpi_scatter: FAIL: no mpirun (apt-get install openmpi-bin)" >&2; exit 1; }
tool() {
    local t
    for t in "$TOOLS/$1" "$TOOLS/$1/$1" "$TOOLS/../$1/$1"; do
        [[ -x $t && -f $t ]] && { echo "$(cd "$(dirname "$t")" && pwd)/$1"; return; }
    done
    echo "mpi_scatter: FAIL: no $1 under $TOOLS" >&2
    exit 1
}
NEBGEN=$(tool nebgen) NEBILLUM=$(tool nebillum) NEBSCATTER=$(tool nebscatter)
if [[ $(id -u) -eq 0 ]]; then # OpenMPI refuses root unless told
    export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
fi
# OpenMPI's own allocations at exit are not ours to report (sanitizer builds).
export ASAN_OPTIONS=${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0
MPIRUN=(mpirun --oversubscribe --bind-to none)

rm -rf "$WORK"
mkdir -p "$WORK"
cd "$WORK"
errors=0
check() { echo "mpi_scatter: check failed: $*" >&2; errors=$((errors + 1)); }
checksums() { grep -ao '"grids":{[^}]*}' "$1" || true; }

"$NEBGEN" --res 24 --seed 3 -q -o n.vdb
"$NEBILLUM" -i n.vdb -q -o lit.vdb
P=(--packets 30000 --seed 7)
"$NEBSCATTER" -i lit.vdb -o one_t1.vdb "${P[@]}" --threads 1 -q
"$NEBSCATTER" -i lit.vdb -o one_t2.vdb "${P[@]}" --threads 2 -q
"${MPIRUN[@]}" -np 2 "$NEBSCATTER" -i lit.vdb -o two.vdb "${P[@]}" --threads 1 -v 2>two.log
"${MPIRUN[@]}" -np 4 "$NEBSCATTER" -i lit.vdb -o four.vdb "${P[@]}" --threads 1 -q

ref=$(checksums one_t1.vdb)
grep -q 'scatter\.stars\.J\.G' <<<"$ref" || check "one_t1.vdb has no scatter.stars.J.G checksum"
grep -q 'scatter\.emission\.J\.G' <<<"$ref" || check "one_t1.vdb has no scatter.emission.J.G checksum"
for f in one_t2.vdb two.vdb four.vdb; do
    [[ $(checksums $f) == "$ref" ]] || check "$f: grid checksums differ from one process's (1 thread)"
done
grep -q "by 2 MPI ranks" two.log || check "two.log does not say 2 MPI ranks computed the field"
n=$(grep -c "wrote two.vdb" two.log || true)
[[ $n == 1 ]] || check "two.log: $n 'wrote' lines, expected 1 (rank 0 only)"

# More ranks than packets.
rc=0
"${MPIRUN[@]}" -np 3 "$NEBSCATTER" -i lit.vdb -o few.vdb --packets 2 -q 2>few.log || rc=$?
[[ $rc -ne 0 ]] || check "3 ranks, 2 packets: exit code 0"
grep -q -- "--packets 2 is fewer than the 3 MPI ranks" few.log || check "few.log does not name --packets and the ranks: $(head -c 300 few.log)"
[[ ! -e few.vdb ]] || check "3 ranks, 2 packets: few.vdb was written"

# stdin reaches rank 0 only.
rc=0
"${MPIRUN[@]}" -np 2 "$NEBSCATTER" -i - -o stdin.vdb -q <lit.vdb 2>stdin.log || rc=$?
[[ $rc -ne 0 ]] || check "-i - with 2 ranks: exit code 0"
grep -q "stdin reaches rank 0 only" stdin.log || check "stdin.log does not explain -i -: $(head -c 300 stdin.log)"
[[ ! -e stdin.vdb ]] || check "-i - with 2 ranks: stdin.vdb was written"

# Ranks that would sum different computations (started with another --packets or --seed, or
# reading another file under the same name): every rank stops before the work, naming what
# differs, and nothing is written.
differ() { # NAME WHAT-THE-MESSAGE-NAMES ARGS-OF-RANK-0 -- ARGS-OF-RANK-1
    local name=$1 what=$2 rc=0
    shift 2
    local a=() b=()
    while [[ $1 != -- ]]; do a+=("$1"); shift; done
    shift
    b=("$@")
    "${MPIRUN[@]}" -np 1 "${a[@]}" : -np 1 "${b[@]}" >"$name.log" 2>&1 || rc=$?
    [[ $rc -ne 0 ]] || check "$name: exit code 0"
    grep -qF "MPI rank 1 of 2 differs from rank 0 in $what" "$name.log" ||
        check "$name: the message does not name $what: $(grep -m1 error "$name.log" | head -c 300)"
    [[ -z $(ls -A out) ]] || check "$name: left $(ls -A out)"
}
mkdir out
differ packets "--packets" "$NEBSCATTER" -i lit.vdb -o out/f.vdb --packets 30000 -q -- \
    "$NEBSCATTER" -i lit.vdb -o out/f.vdb --packets 20000 -q
differ seed "--seed" "$NEBSCATTER" -i lit.vdb -o out/f.vdb --seed 1 -q -- \
    "$NEBSCATTER" -i lit.vdb -o out/f.vdb --seed 2 -q
# The same name, another file: each rank in its own folder (mpirun --wdir per rank).
mkdir other
"$NEBGEN" --res 24 --seed 4 -q -o other/n.vdb
"$NEBILLUM" -i other/n.vdb -q -o other/lit.vdb
differ input "the input -i lit.vdb (another file's grids)" --wdir "$WORK" "$NEBSCATTER" -i lit.vdb -o "$WORK/out/f.vdb" -q -- \
    --wdir "$WORK/other" "$NEBSCATTER" -i lit.vdb -o "$WORK/out/f.vdb" -q
# --threads and -v may differ: the same field as before.
"${MPIRUN[@]}" -np 1 "$NEBSCATTER" -i lit.vdb -o mixed.vdb "${P[@]}" --threads 1 -q : \
    -np 1 "$NEBSCATTER" -i lit.vdb -o mixed.vdb "${P[@]}" --threads 2 -v 2>mixed.log ||
    check "ranks with different --threads and -v: $(head -c 300 mixed.log)"
[[ $(checksums mixed.vdb) == "$ref" ]] || check "mixed.vdb: grid checksums differ from one process's"

# A rank that dies: rank 1 is killed once it has run a second; the launcher must stop rank 0
# before it writes, and leave no temporary.
mkdir die
rc=0
timeout 120 "${MPIRUN[@]}" -np 2 bash -c '
    if [[ ${OMPI_COMM_WORLD_RANK:-0} == 1 ]]; then
        "$0" "$@" & pid=$!; sleep 1; kill -9 $pid; wait $pid; exit 137
    fi
    exec "$0" "$@"' "$NEBSCATTER" -i lit.vdb -o die/killed.vdb --packets 20000000 --threads 1 -q \
    >die.log 2>&1 || rc=$?
[[ $rc -ne 0 ]] || check "a killed rank: mpirun exit code 0"
[[ $rc -ne 124 ]] || check "a killed rank: the run hung (timeout 120 s)"
left=$(ls -A die)
[[ -z $left ]] || check "a killed rank left files: $left"

if ((errors)); then
    echo "mpi_scatter: FAIL: $errors check(s)" >&2
    exit 1
fi
echo "mpi_scatter: 1, 2 and 4 ranks and 1 or 2 threads gave the same field; bad runs refused, a killed rank left nothing"
