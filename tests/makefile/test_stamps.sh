#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Makefile.data redoes a step when a variable it uses changes, and only then: the example
# pipeline is run with stub tools that log their calls, then run again (nothing to do), then
# with another RES (everything from nebgen on), then another SCATTER_FLAGS (nebscatter and
# nebrender only), and LEVELS, which the default picture does not use (nothing), but the
# seed-method picture nebula-rnv.png does (nebpyramid and nebrender).
#
#   tests/makefile/test_stamps.sh SOURCE_DIR WORK_DIR
set -euo pipefail
src=$1
work=$2
rm -rf "$work"
mkdir -p "$work/tools"
log=$work/calls.log
for tool in nebgen nebillum nebpyramid nebphase nebscatter nebrender; do
    cat > "$work/tools/$tool" <<STUB
#!/usr/bin/env bash
# Stub: logs its name and arguments, creates the files named by -o and --png.
echo "$tool \$*" >> "$log"
while [[ \$# -gt 0 ]]; do
    case \$1 in -o|--png) echo stub > "\$2"; shift ;; esac
    shift
done
STUB
    chmod +x "$work/tools/$tool"
done

run() {  # run [TARGET] VAR=VALUE...: the example pipeline's last target (or out/TARGET);
         # prints the tools it called
    local target=nebula.png
    if [[ $1 != *=* ]]; then target=$1; shift; fi
    : > "$log"
    make -s -f "$src/Makefile.data" -C "$src" TOOLS="$work/tools" OUT="$work/out" "$@" \
        "$work/out/$target" >/dev/null
    cut -d' ' -f1 "$log" | sort | tr '\n' ' '
}
expect() {  # expect WHAT GOT WANT
    if [[ $2 != "$3" ]]; then
        echo "test_stamps: FAIL: $1: ran [$2], expected [$3]" >&2
        exit 1
    fi
    echo "ok: $1: [$2]"
}
expect "first run" "$(run RES=16)" "nebgen nebillum nebrender nebscatter "
expect "nothing changed" "$(run RES=16)" ""
expect "RES changed" "$(run RES=24)" "nebgen nebillum nebrender nebscatter "
expect "SCATTER_FLAGS changed" "$(run RES=24 SCATTER_FLAGS=--order=3)" "nebrender nebscatter "
expect "LEVELS changed, unused" "$(run RES=24 SCATTER_FLAGS=--order=3 LEVELS=2)" ""
expect "seed's method" "$(run nebula-rnv.png RES=24 LEVELS=2)" "nebphase nebpyramid nebrender "
expect "LEVELS changed" "$(run nebula-rnv.png RES=24 LEVELS=3)" "nebpyramid nebrender "
expect "RENDER_FLAGS changed" "$(run RES=24 SCATTER_FLAGS=--order=3 RENDER_FLAGS=--rv=5)" "nebrender "
expect "back to the same" "$(run RES=24 SCATTER_FLAGS=--order=3 RENDER_FLAGS=--rv=5)" ""
echo "test_stamps: PASS"
