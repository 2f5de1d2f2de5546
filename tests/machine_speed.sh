#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# How many times slower than an idle 2-core machine this one runs now: an integer from 1 to
# 8, printed on stdout. Makefile.data's test target passes it to ctest as
# NEBULA_TEST_TIME_SCALE, and the long tests' time-outs are multiplied by it
# (tests/CMakeLists.txt, scale_timeouts.cmake), so a suite that shares the machine with
# another job gets the time it needs, while a hang is still caught.
#
# The measure: the median wall time of three runs of a fixed Python loop (about 0.35 s idle),
# against NOMINAL_MS, its time on an idle machine of the CI kind (measured with nothing else
# running: 2 cores, Debian 12's python3).
set -euo pipefail
NOMINAL_MS=${NOMINAL_MS:-400}
# Debian's interpreter, not a version manager's shim (whose start-up is slow and varies).
PY=/usr/bin/python3
[[ -x $PY ]] || PY=python3
times=()
for _ in 1 2 3; do
    start=$(date +%s%N)
    "$PY" -c '
x = 0
for i in range(3_000_000):
    x += i * i
'
    end=$(date +%s%N)
    times+=($(((end - start) / 1000000)))
done
median=$(printf '%s\n' "${times[@]}" | sort -n | sed -n 2p)
scale=$(((median + NOMINAL_MS - 1) / NOMINAL_MS))
((scale < 1)) && scale=1
((scale > 8)) && scale=8
echo "machine_speed: median ${median} ms against ${NOMINAL_MS} ms idle: time-outs x${scale}" >&2
echo "$scale"
