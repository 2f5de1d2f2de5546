#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The longest functions of libnebula, by clang-tidy's readability-function-size check (lines
# of the body, comments and blank lines included), longest first.
#
#   bench/function_sizes.sh [BUILD] [N]     N: how many to print (default 10)
#
# BUILD (default build) is an existing build folder; it is reconfigured with
# CMAKE_EXPORT_COMPILE_COMMANDS=ON for clang-tidy. Every libnebula source is checked.
set -euo pipefail
build=${1:-build}
top=${2:-10}
[[ -f $build/CMakeCache.txt ]] || { echo "function_sizes: error: $build is not a build folder" >&2; exit 1; }
command -v clang-tidy >/dev/null || { echo "function_sizes: error: clang-tidy not found (apt-get install clang-tidy)" >&2; exit 1; }
cmake -DCMAKE_EXPORT_COMPILE_COMMANDS=ON "$build" >/dev/null
src=$(sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$build/CMakeCache.txt")
config='{Checks: "-*,readability-function-size", CheckOptions: [{key: readability-function-size.LineThreshold, value: 40}]}'
find "$src/libnebula/src" -name '*.cpp' | sort | while read -r f; do
    clang-tidy -p "$build" --config="$config" "$f" 2>/dev/null || true
done | awk '
    /warning: function .* exceeds recommended size/ {
        match($0, /function \x27[^\x27]*\x27/); name = substr($0, RSTART + 10, RLENGTH - 11)
        split($1, where, ":"); file = where[1]; sub(".*/libnebula/", "libnebula/", file)
    }
    /note: [0-9]+ lines including/ { n = $3; print n "\t" name "\t" file ":" where[2] }
' | sort -rn -u | head -n "$top"
