#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Runs the libFuzzer targets for a bounded time from the committed seed corpus, and fails on
# any finding.
# Usage: run_fuzz.sh FUZZ_BUILD_DIR [SECONDS]   (default 60: the eleven targets run side by
# side for SECONDS of wall time each, which keeps both cores of a CI machine busy)
# Targets: the VDB structure checker and the grid reader (corpus/grid), the star and dust
# parsers (corpus/metadata), every JSON consumer (corpus/json, with deep and wide documents),
# config files (corpus/config), nebimport's cube formats: .npy headers (corpus/npy),
# RADMC-3D's grid and density headers (corpus/radmc), FITS files, plain and gzipped
# (corpus/fits: the gzip branch inflates within the declared size), HDF5 files (corpus/hdf5,
# written by tests/fuzz/make_hdf5_corpus.py), filter
# files (corpus/filter), and nebview's WebSocket messages (corpus/view).
# The corpus grows in a scratch copy (FUZZ_BUILD_DIR/corpus); a finding is saved as
# FUZZ_BUILD_DIR/findings/crash-* (or leak-*, oom-*, timeout-*). Keep it as a regression
# test: copy it into tests/fuzz/regressions/ (the unit test
# DamagedInputs.FuzzRegressionsAreRefusedOrRead replays every file there).
set -euo pipefail
build=$1
seconds=${2:-60}
src=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$build/findings"

run_target() { # target seeds seconds max_len [more libFuzzer flags]
    local target=$1 seeds=$2 time=$3 max_len=$4
    shift 4
    local corpus=$build/corpus/$target
    mkdir -p "$corpus"
    # -rss_limit_mb / -malloc_limit_mb: an allocation out of proportion to the input is a
    # finding too.
    # lsan.supp: leaks inside libhdf5 on damaged headers (the library's; see the file).
    ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=0 \
    LSAN_OPTIONS=suppressions=$src/lsan.supp:print_suppressions=0 \
    UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
        "$build/tests/fuzz/$target" -max_total_time="$time" -timeout=10 -rss_limit_mb=2048 \
            -malloc_limit_mb=512 -max_len="$max_len" -print_final_stats=1 \
            -artifact_prefix="${ARTIFACTS:-$build/findings/}" "$@" "$corpus" "$seeds" \
            > "$build/$target.log" 2>&1
}

# libhdf5 1.10.8 (Debian 12) itself crashes, loops or allocates without bound on some damaged
# metadata (object headers, local and global heaps, symbol tables) before nebula can check
# anything: fuzz_hdf5 runs in fork mode past such inputs, and each one is replayed here: one
# whose first frame in libhdf5 or in nebula (outside the sanitizer, libFuzzer and libc) is in
# libhdf5 is kept apart in findings-libhdf5/ (listed, not a failure: the library's bug, see
# regressions/README.md); one that does not fail when replayed alone, in
# findings-unreproduced/ (listed); any other is a finding like the other targets'. Frames are told
# apart by where they are, not by what is left out: libc's frames may carry its source paths
# (nptl/pthread_kill.c, debug/chk_fail.c) instead of libc.so, as on an abort from one of
# libhdf5's own fortified calls.
sort_hdf5_findings() {
    local dir=$build/findings-hdf5 file frame root out rc
    root=$(cd "$src/../.." && pwd)
    mkdir -p "$build/findings-libhdf5" "$build/findings-unreproduced"
    for file in "$dir"/*; do
        [[ -f $file ]] || continue
        rc=0
        out=$(ASAN_OPTIONS=detect_leaks=0 timeout 60 "$build/tests/fuzz/fuzz_hdf5" -timeout=10 \
            -rss_limit_mb=2048 -malloc_limit_mb=512 \
            "$file" 2>&1) || rc=$?
        if ((rc == 0)); then
            # Failed in fork mode, where one process reads many inputs, but not alone: the
            # state libhdf5 keeps between files (ASan stops nebula's own memory errors where
            # they happen, so they fail alone too). Listed, not a failure.
            mv "$file" "$build/findings-unreproduced/"
            continue
        fi
        frame=$(grep -E '^ +#[0-9]+ ' <<<"$out" |
            grep -vE 'sanitizer|asan|ubsan|interceptor|fuzzer::|<unknown module>' |
            grep -vE ' in (malloc|calloc|realloc|free|memcpy|memmove|memset|operator new) ' |
            grep -E "libhdf5|fuzz_hdf5|$root/" | head -1 || true)
        if [[ $frame == *libhdf5* ]]; then
            mv "$file" "$build/findings-libhdf5/"
        else
            mv "$file" "$build/findings/"
        fi
    done
}

status=0
pids=()
# Text inputs are fuzzed at most 4 KiB long: JSON's nesting limit (64) and the config's line
# rules are reached within a few hundred bytes, and short inputs run 10x more often (the
# deep and wide seeds are cut to 4 KiB, still 60 times too deep).
run_target fuzz_vdb_check "$src/corpus/grid" "$seconds" 65536 & pids+=($!)
run_target fuzz_grid_reader "$src/corpus/grid" "$seconds" 65536 & pids+=($!)
run_target fuzz_metadata "$src/corpus/metadata" "$seconds" 65536 & pids+=($!)
run_target fuzz_json "$src/corpus/json" "$seconds" 4096 & pids+=($!)
run_target fuzz_config "$src/corpus/config" "$seconds" 4096 & pids+=($!)
run_target fuzz_npy_header "$src/corpus/npy" "$seconds" 4096 & pids+=($!)
run_target fuzz_radmc "$src/corpus/radmc" "$seconds" 4096 & pids+=($!)
# FITS comes in 2880-byte blocks: a header and a little data fit in 16 KiB.
run_target fuzz_fits "$src/corpus/fits" "$seconds" 16384 & pids+=($!)
# HDF5: a superblock, a few object headers, B-tree nodes and a little data fit in 16 KiB.
mkdir -p "$build/findings-hdf5"
{ # its status: sort_hdf5_findings decides
    ARTIFACTS=$build/findings-hdf5/ run_target fuzz_hdf5 "$src/corpus/hdf5" "$seconds" 16384 \
        -fork=1 -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1 || true
} & pids+=($!)
run_target fuzz_filter_file "$src/corpus/filter" "$seconds" 4096 & pids+=($!)
run_target fuzz_view_message "$src/corpus/view" "$seconds" 4096 & pids+=($!)
for pid in "${pids[@]}"; do wait "$pid" || status=1; done
sort_hdf5_findings
total=0
for target in fuzz_vdb_check fuzz_grid_reader fuzz_metadata fuzz_json fuzz_config fuzz_npy_header \
    fuzz_radmc fuzz_fits fuzz_hdf5 fuzz_filter_file fuzz_view_message; do
    echo "== $target (${seconds} s)"
    grep -E "stat::number_of_executed_units|stat::average_exec_per_sec|stat::peak_rss_mb" \
        "$build/$target.log" | sed "s/^/  /" || true
    runs=$(grep -oE "number_of_executed_units: *[0-9]+" "$build/$target.log" |
        grep -oE "[0-9]+$" || echo 0)
    if [[ $target == fuzz_hdf5 ]]; then # fork mode: the last "#N:" progress line
        runs=$(grep -oE "^#[0-9]+:" "$build/$target.log" | tail -1 | tr -dc 0-9)
        runs=${runs:-0}
        echo "  executions: $runs; inputs on which libhdf5 itself failed:" \
            "$(find "$build/findings-libhdf5" -type f | wc -l) (in $build/findings-libhdf5);" \
            "failed in fork mode only: $(find "$build/findings-unreproduced" -type f | wc -l)" \
            "(in $build/findings-unreproduced)"
    fi
    total=$((total + runs))
    if [[ $target != fuzz_hdf5 ]] && grep -qE "ERROR|deadly signal|SUMMARY" "$build/$target.log"; then
        tail -40 "$build/$target.log"
    fi
done
echo "executions in all: $total"
text=0
for target in fuzz_json fuzz_config; do
    runs=$(grep -oE "number_of_executed_units: *[0-9]+" "$build/$target.log" |
        grep -oE "[0-9]+$" || echo 0)
    text=$((text + runs))
done
echo "executions of the JSON and config targets: $text"
if ls "$build"/findings/* > /dev/null 2>&1; then
    echo "fuzzing found inputs that fail (kept in $build/findings):"
    ls -l "$build"/findings
    exit 1
fi
exit $status
