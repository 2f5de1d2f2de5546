#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Compile time of every libnebula translation unit, one at a time (so the figures do not
# depend on how many run in parallel), slowest first.
#
#   bench/compile_times.sh [BUILD] [N]     N: how many to print (default 10)
#
# BUILD (default build), an existing build folder (built once, for the generated headers), is
# reconfigured with CMAKE_EXPORT_COMPILE_COMMANDS=ON; each command of compile_commands.json
# under libnebula/ is rerun with -o /dev/null.
set -euo pipefail
build=${1:-build}
top=${2:-10}
[[ -f $build/CMakeCache.txt ]] || { echo "compile_times: error: $build is not a build folder" >&2; exit 1; }
cmake -DCMAKE_EXPORT_COMPILE_COMMANDS=ON "$build" >/dev/null
python3 - "$build/compile_commands.json" "$top" <<'PY'
import json, shlex, subprocess, sys, time
entries = [e for e in json.load(open(sys.argv[1])) if "/libnebula/" in e["file"]]
times = []
for e in entries:
    args = shlex.split(e["command"])
    out = args.index("-o")
    args[out + 1] = "/dev/null"
    start = time.perf_counter()
    subprocess.run(args, cwd=e["directory"], check=True)
    times.append((time.perf_counter() - start, e["file"].split("/libnebula/")[1]))
times.sort(reverse=True)
total = sum(t for t, _ in times)
print(f"{len(times)} units, {total:.1f} s in all, one at a time")
for t, f in times[: int(sys.argv[2])]:
    print(f"{t:7.1f} s  libnebula/{f}")
PY
