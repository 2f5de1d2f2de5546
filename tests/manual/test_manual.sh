#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The generated man pages and bash completion (cli/manual.h) of every tool:
# - `MANWIDTH=80 man --warnings -l PAGE` renders each page without a warning;
# - each page lists every option that `TOOL --help` lists;
# - sourced in bash, `complete -p TOOL` exists, and completing `nebrender --cam` offers
#   --camera and --camera-path, and `nebimport --emi` --emission and --emission-unit.
#   test_manual.sh BUILD_DIR
set -euo pipefail
build=$1
tools=(nebgen nebillum nebionize nebrender nebphase nebpyramid nebscatter nebtone nebimport nebexport nebstats nebview)
command -v man > /dev/null || { echo "SKIP: man (man-db) is not installed" >&2; exit 77; }
fail=0
for t in "${tools[@]}"; do
    page=$build/man/$t.1
    [[ -s $page ]] || { echo "FAIL: $page missing" >&2; fail=1; continue; }
    warnings=$(MANWIDTH=80 man --warnings -l "$page" 2>&1 > /dev/null || true)
    if [[ -n $warnings ]]; then
        echo "FAIL: $t.1: man warns: $warnings" >&2
        fail=1
    fi
    text=$(MANWIDTH=200 man -l "$page" 2> /dev/null | col -b)
    # Every long option --help lists (lines of the options' column start with blanks and -).
    options=$("$build/tools/$t" --help | grep -oE '^ +(-[A-Za-z], *)?--[A-Za-z0-9-]+' |
        grep -oE -- '--[A-Za-z0-9-]+' | sort -u)
    n=0
    for o in $options; do
        n=$((n + 1))
        grep -qF -- "$o" <<< "$text" || { echo "FAIL: $t.1 lacks $o" >&2; fail=1; }
    done
    [[ $n -gt 5 ]] || { echo "FAIL: $t --help lists only $n options" >&2; fail=1; }
    grep -q "EXIT STATUS" <<< "$text" || { echo "FAIL: $t.1 has no EXIT STATUS" >&2; fail=1; }
    echo "ok   $t.1: renders without warnings, lists all $n options of --help"
done
complete_words() { # TOOL WORD: what bash completion offers for "TOOL WORD"
    bash -c 'source "$1"; complete -p "$2" > /dev/null; COMP_WORDS=("$2" "$3"); COMP_CWORD=1
             "_nebula_$2"; printf "%s\n" "${COMPREPLY[@]}"' sh "$build/completion/$1" "$1" "$2"
}
# TOOL WORD WANTED...: completing "TOOL WORD" offers each of WANTED.
for check in "nebrender --cam --camera --camera-path" "nebimport --emi --emission --emission-unit"; do
    read -r tool word wanted <<< "$check"
    offered=$(complete_words "$tool" "$word")
    for w in $wanted; do
        grep -qx -- "$w" <<< "$offered" || { echo "FAIL: $tool $word offers: $offered" >&2; fail=1; }
    done
    echo "ok   $tool $word<Tab>: $(tr '\n' ' ' <<< "$offered")"
done
exit $fail
