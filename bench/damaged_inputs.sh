#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Damaged inputs through a real tool, with counts by outcome and the peak RSS
# (docs/failures.md; the fixed-seed unit tests DamagedInputs.* cover the same in process).
# Makes a small lit nebula, then runs `nebillum -i in.vdb -o out.vdb` on
#   - N mutants (1-4 bytes XORed with random values, fixed seed),
#   - the file missing its last 1..32 bytes, and cut to 10, 100 bytes and half, as a file and
#     through a pipe,
# and sorts each run into: refused (exit 1 or 2 with one "error:" line), identical (exit 0 and
# the output's nebula:checksums equal the original's: nothing that matters was hit),
# DIFFERENT (exit 0 but other contents: a silent acceptance), CRASH (signal), HANG (> 20 s).
# Usage: bench/damaged_inputs.sh [TOOLS_DIR] [N]     (default build/tools, 450)
set -euo pipefail
tools=$(cd "${1:-build/tools}" && pwd)
n=${2:-450}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
"$tools/nebgen" --res 24 --seed 3 -o small.vdb
"$tools/nebillum" -i small.vdb -o lit.vdb
size=$(stat -c %s small.vdb)
cp small.vdb in.vdb
"$tools/nebillum" -i in.vdb -o out.vdb
checksums() { vdb_print -metadata "$1" 2>/dev/null | grep 'nebula:checksums' || true; }
reference=$(checksums out.vdb)

declare -A count
peak=0
classify() { # $1: how the input is given ("file" or "pipe")
    rm -f out.vdb
    local status=0
    if [ "$1" = pipe ]; then
        cat in.vdb | /usr/bin/time -f '%M' -o rss.txt timeout 20 "$tools/nebillum" -i - -o out.vdb \
            2> err.txt || status=$?
    else
        /usr/bin/time -f '%M' -o rss.txt timeout 20 "$tools/nebillum" -i in.vdb -o out.vdb \
            2> err.txt || status=$?
    fi
    local rss
    rss=$(grep -E '^[0-9]+$' rss.txt | tail -1 || echo 0)
    [ "${rss:-0}" -gt "$peak" ] && peak=$rss
    local outcome
    if [ "$status" = 124 ]; then outcome=HANG
    elif [ "$status" -gt 128 ] || grep -q "terminated by signal" rss.txt; then outcome=CRASH
    elif [ "$status" = 0 ]; then
        if [ "$(checksums out.vdb)" = "$reference" ]; then outcome=identical; else outcome=DIFFERENT; fi
    elif [ "$(grep -c 'error:' err.txt)" = 1 ] && [ "$(wc -l < err.txt)" = 1 ]; then outcome=refused
    else outcome=BAD-MESSAGE; fi
    count[$outcome]=$(( ${count[$outcome]:-0} + 1 ))
    if [ "$outcome" != refused ] && [ "$outcome" != identical ]; then
        echo "  $outcome: $2: $(head -c 300 err.txt)"
    fi
}

python3 - "$n" small.vdb <<'PY'
import random, sys
n, src = int(sys.argv[1]), sys.argv[2]
data = open(src, 'rb').read()
rng = random.Random(20261202)
for m in range(n):
    b = bytearray(data)
    for _ in range(rng.randint(1, 4)):
        b[rng.randrange(len(b))] ^= rng.randint(1, 255)
    open(f'mutant{m}.vdb', 'wb').write(b)
PY
for ((m = 0; m < n; m++)); do
    cp "mutant$m.vdb" in.vdb
    classify file "mutant $m"
done
for cut in $(seq 1 32) $((size - 10)) $((size - 100)) $((size / 2)); do
    head -c $((size - cut)) small.vdb > in.vdb
    classify file "missing $cut bytes"
    classify pipe "missing $cut bytes (pipe)"
done
echo "input: $size bytes ($n mutants, 35 truncations as file and pipe)"
for k in "${!count[@]}"; do echo "  $k: ${count[$k]}"; done | sort
echo "peak RSS over all runs: $peak KB (the undamaged run: see below)"
/usr/bin/time -f 'undamaged nebillum: %M KB peak RSS' "$tools/nebillum" -i small.vdb -o out.vdb
