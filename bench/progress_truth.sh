#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Whether nebrender's progress lines tell the truth: renders the tilted dome master of
# docs/cameras.md (bench/dome_master.sh's view) from SCATTERED.vdb with -v and stderr in a
# file, stamps each progress line with the time it was written, and compares each line's
# "time left" with the time the render then really took to finish ("done in").
#
# Usage: bench/progress_truth.sh SCATTERED.vdb [SIZE] [-- EXTRA nebrender options]
#   SIZE: the dome master's edge (default 4096).
# Environment: TOOLS (default build/tools), KEEP=1 keeps the temp dir.
# SCATTERED.vdb: the README example through nebscatter, e.g.
#   nebgen --preset reflection --res 128 -o n.vdb; nebillum -i n.vdb -o lit.vdb
#   nebscatter -i lit.vdb -o s.vdb
# Prints one row per progress line: per cent done, elapsed [s], the line's time left as
# written, the same to the second (elapsed x (100 - per cent) / per cent, the formula the line
# rounds to minutes past 2 min), the true time left [s] and predicted / true; then the worst
# ratio from 20 % done on (target: within 0.75-1.25; a line of 99.5 % and more, printed as
# 100 %, is left out of it).
set -euo pipefail

TOOLS=${TOOLS:-build/tools}
SCRIPT=progress_truth
# shellcheck source=bench/common.sh
source "$(dirname "$0")/common.sh"
(($#)) || { echo "usage: bench/progress_truth.sh SCATTERED.vdb [SIZE] [-- OPTIONS]" >&2; exit 2; }
INPUT=$(realpath "$1")
shift
SIZE=4096
if (($#)) && [[ $1 != -- ]]; then
    SIZE=$1
    shift
fi
[[ $SIZE =~ ^[0-9]+$ && $SIZE -ge 16 ]] || { echo "$SCRIPT: error: size '$SIZE' is not a whole number >= 16" >&2; exit 2; }
(($#)) && [[ $1 == -- ]] && shift
[[ -r $INPUT ]] || { echo "$SCRIPT: error: cannot read $INPUT" >&2; exit 2; }
bench_require "$TOOLS/nebrender"
TOOLS=$(cd "$TOOLS" && pwd)
bench_tmpdir

echo "machine: $(nproc) cores; load average $(cut -d' ' -f1-3 /proc/loadavg)"
echo "nebrender -i $INPUT --camera fisheye --dome-tilt 25 --eye 0.5,0.5,-2 --res ${SIZE}x$SIZE -v $*"
# Each stderr line with the wall time it arrived.
"$TOOLS/nebrender" -i "$INPUT" --camera fisheye --dome-tilt 25 --eye 0.5,0.5,-2 \
    --res "${SIZE}x$SIZE" --no-png -v "$@" -o dome.exr 2>&1 >/dev/null |
    while IFS= read -r line; do printf '%s %s\n' "$(date +%s.%N)" "$line"; done >stamped.log

/usr/bin/python3 - stamped.log <<'EOF'
import re, sys
units = {"s": 1, "min": 60, "h": 3600, "days": 86400}
rows, done_at = [], None
for raw in open(sys.argv[1]):
    stamp, _, line = raw.rstrip("\n").partition(" ")
    t = float(stamp)
    m = re.match(r"nebrender(?: path)?: (\d+) % after ([\d.]+) (s|min|h|days)(?:, ([\d.]+) (s|min|h|days) left)?", line)
    if m:
        left = float(m.group(4)) * units[m.group(5)] if m.group(4) else None
        rows.append((t, int(m.group(1)), float(m.group(2)) * units[m.group(3)], left))
    elif re.match(r"nebrender(?: path)?: done in ", line):
        done_at = t
if done_at is None or not rows:
    sys.exit("progress_truth: error: no progress lines or no 'done' line in the log")
print("%5s %10s %10s %12s %10s %8s" % ("done%", "elapsed_s", "line_s", "predicted_s", "true_s", "ratio"))
worst = 1.0
for t, pct, elapsed, left in rows:
    true_left = done_at - t
    predicted = elapsed * (100 - pct) / pct if pct > 0 and elapsed > 2 else None
    ratio = predicted / true_left if predicted is not None and true_left > 0 else float("nan")
    print("%5d %10.0f %10s %12s %10.1f %8.2f" % (pct, elapsed, "-" if left is None else "%.0f" % left,
          "-" if predicted is None else "%.1f" % predicted, true_left, ratio))
    if 20 <= pct < 100 and ratio == ratio and abs(ratio - 1) > abs(worst - 1):
        worst = ratio
print("worst predicted/true from 20 %% done on: %.2f (%s)" % (worst, "within 25 %" if abs(worst - 1) <= 0.25 else "off by more than 25 %"))
EOF
