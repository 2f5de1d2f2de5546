#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The longest functions of libnebula and the tools, by clang-tidy's readability-function-size
# check (lines of the body, comments and blank lines included), longest first.
#
#   bench/function_sizes.sh [--over LINES] [--only PATH]... [BUILD] [N]
#
# BUILD (default build) is an existing build folder; it is reconfigured with
# CMAKE_EXPORT_COMPILE_COMMANDS=ON for clang-tidy. Every source of libnebula/src and tools/ is
# checked, with the headers of libnebula/ and tools/ they include (a function in a header is
# listed once). N: how many to print (default 10).
# --over LINES: print every function longer than LINES lines instead of the top N, and exit 1
# if there is any (the limit the code keeps: bench/function_sizes.sh --over 150).
# --only PATH: check only the sources under PATH (a file or folder, relative to the source
# tree; repeatable), e.g. --only tools/nebgen --only libnebula/src/stages/phase.cpp.
set -euo pipefail
usage() { echo "usage: bench/function_sizes.sh [--over LINES] [--only PATH]... [BUILD] [N]" >&2; exit 2; }
over=
only=()
positional=()
while (($#)); do
    case $1 in
        --over) (($# >= 2)) || usage; over=$2; shift 2 ;;
        --only) (($# >= 2)) || usage; only+=("$2"); shift 2 ;;
        -h|--help) sed -n '3,16s/^# \{0,1\}//p' "$0"; exit 0 ;;
        -*) usage ;;
        *) positional+=("$1"); shift ;;
    esac
done
((${#positional[@]} <= 2)) || usage
build=${positional[0]:-build}
top=${positional[1]:-10}
[[ -z $over || $over =~ ^[0-9]+$ ]] || { echo "function_sizes: error: --over needs a number of lines, got $over" >&2; exit 2; }
[[ $top =~ ^[0-9]+$ ]] || { echo "function_sizes: error: N must be a number, got $top" >&2; exit 2; }
[[ -f $build/CMakeCache.txt ]] || { echo "function_sizes: error: $build is not a build folder" >&2; exit 1; }
command -v clang-tidy >/dev/null || { echo "function_sizes: error: clang-tidy not found (apt-get install clang-tidy)" >&2; exit 1; }
cmake -DCMAKE_EXPORT_COMPILE_COMMANDS=ON "$build" >/dev/null 2>&1 ||
    { echo "function_sizes: error: cmake could not reconfigure $build" >&2; exit 1; }
src=$(sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$build/CMakeCache.txt")
((${#only[@]})) || only=(libnebula/src tools)
threshold=${over:-40}
config="{Checks: \"-*,readability-function-size\", CheckOptions: [{key: readability-function-size.LineThreshold, value: $threshold}]}"
list=$(for p in "${only[@]}"; do
    [[ -e $src/$p ]] || { echo "function_sizes: error: $src/$p does not exist" >&2; exit 1; }
    find "$src/$p" -name '*.cpp'
done | sort -u)
table=$(for f in $list; do
    clang-tidy -p "$build" --config="$config" --header-filter="^$src/(libnebula|tools)/" "$f" 2>/dev/null || true
done | awk -v root="$src/" '
    /warning: function .* exceeds recommended size/ {
        match($0, /function \x27[^\x27]*\x27/); name = substr($0, RSTART + 10, RLENGTH - 11)
        split($1, where, ":"); file = where[1]
        if (index(file, root) == 1) file = substr(file, length(root) + 1)
    }
    /note: [0-9]+ lines including/ { n = $3; print n "\t" name "\t" file ":" where[2] }
' | sort -u | sort -t "$(printf '\t')" -k1,1rn -k3,3)
if [[ -n $over ]]; then
    [[ -z $table ]] || { echo "$table"; exit 1; }
    echo "function_sizes: no function over $over lines" >&2
else
    [[ -z $table ]] || echo "$table" | head -n "$top"
fi
