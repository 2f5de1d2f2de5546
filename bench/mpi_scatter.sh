#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# nebscatter over MPI ranks against one process on this machine: the same cores as
# 1 rank x 2 threads and as 2 ranks x 1 thread (mpirun -np 2 --bind-to none), RUNS times each,
# alternating, wall time and peak memory per process (/usr/bin/time -v around the tool; for
# the ranks, mpirun runs /usr/bin/time per rank), and the field checksums of every run (must
# all be equal).
#
# Usage: bench/mpi_scatter.sh LIT.vdb [TOOLS_DIR]   (default TOOLS_DIR: build/tools)
# Environment: PACKETS (default 1000000), RUNS (default 3), KEEP=1 keeps the temp dir.
set -euo pipefail

LIT=${1:?usage: bench/mpi_scatter.sh LIT.vdb [TOOLS_DIR]}
TOOLS=${2:-build/tools}
PACKETS=${PACKETS:-1000000}
RUNS=${RUNS:-3}
SCRIPT=mpi_scatter
# shellcheck source=bench/common.sh
source "$(dirname "$0")/common.sh"
bench_require "$TIME" "$TOOLS/nebscatter"
command -v mpirun >/dev/null || { echo "$SCRIPT: error: no mpirun (apt-get install openmpi-bin)" >&2; exit 1; }
TOOLS=$(cd "$TOOLS" && pwd)
LIT=$(cd "$(dirname "$LIT")" && pwd)/$(basename "$LIT")
bench_tmpdir
if [[ $(id -u) -eq 0 ]]; then export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1; fi

echo "machine: $(nproc) cores, $(awk '/MemTotal/ { printf "%.1f GiB", $2 / 1048576 }' /proc/meminfo); load average $(cut -d' ' -f1-3 /proc/loadavg)"
echo "scene: $LIT, --packets $PACKETS"
sums=()
for ((i = 1; i <= RUNS; ++i)); do
    $TIME -v -o one$i.time "$TOOLS/nebscatter" -i "$LIT" -o one$i.vdb --packets "$PACKETS" \
        --threads 2 -q
    mpirun -np 2 --bind-to none sh -c '"$0" -v -o "two'$i'.$OMPI_COMM_WORLD_RANK.time" "$@"' \
        "$TIME" "$TOOLS/nebscatter" -i "$LIT" -o two$i.vdb --packets "$PACKETS" --threads 1 -q
    printf "run %d: 1 rank x 2 threads %7.2f s, %6.0f MiB | 2 ranks x 1 thread %7.2f s, %6.0f + %6.0f MiB\n" \
        "$i" "$(wall one$i)" "$(awk -v k="$(maxrss one$i)" 'BEGIN { print k / 1024 }')" \
        "$(wall two$i.0)" "$(awk -v k="$(maxrss two$i.0)" 'BEGIN { print k / 1024 }')" \
        "$(awk -v k="$(maxrss two$i.1)" 'BEGIN { print k / 1024 }')"
    sums+=("$(grep -ao '"grids":{[^}]*}' one$i.vdb | md5sum)" "$(grep -ao '"grids":{[^}]*}' two$i.vdb | md5sum)")
done
if [[ $(printf '%s\n' "${sums[@]}" | sort -u | wc -l) == 1 ]]; then
    echo "field checksums: all $((2 * RUNS)) runs equal"
else
    echo "field checksums: DIFFER"; exit 1
fi
