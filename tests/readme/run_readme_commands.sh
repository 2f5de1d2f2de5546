#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Runs the shell commands of the README's and the docs pages' examples, in order, as a new
# user would type them.
#
#   run_readme_commands.sh TOOLS_DIR WORK_DIR [PAGE.md ...]
#
# TOOLS_DIR: where the tools are, either as TOOLS_DIR/<tool> or as TOOLS_DIR/<tool>/<tool>
# (CTest passes $<TARGET_FILE_DIR:nebgen>, so TOOLS_DIR/../<tool>/<tool> is looked at too);
# they are put first on PATH, so the pages' plain `nebgen ...` runs them. WORK_DIR is
# created if needed and the commands run in it; a WORK_DIR left by an earlier run (it holds
# .readme-test) is emptied first, any other non-empty one is refused.
#
# PAGES: the markdown files whose examples run, in the order given. Without any, the pages
# listed in tests/readme/pages.txt, in its order (README.md first, then the docs pages in the
# order their examples once had in the README: later examples use files earlier ones made,
# so the order matters). With that list, a page of README.md or docs/ that has a block to run
# but is not listed is an error, so that no example is left out unnoticed.
#
# What runs: every line of every ```sh or ```bash block (a line ending in \ continues on the
# next), each with `bash -euo pipefail` in WORK_DIR, page after page and in page order, so
# later examples use the files earlier ones made. Blank lines and comment lines are not
# commands. A block is left out only when its page says so: the line before its opening
# fence (blank lines between allowed) is an HTML comment starting `<!-- readme-test: skip`
# (invisible on the rendered page; say why in it), for blocks that install packages, build
# the project, run minutes-long renders or benchmarks, or need Blender or files the pages do
# not make. Nothing is resized here: the examples are kept small enough to run in seconds.
# The commands speak from the top of a checkout: WORK_DIR/examples links to this checkout's
# examples/ folder (camera paths).
#
# Exit 0 when every command succeeded; otherwise 1, naming the page and line of the first
# command that failed, with its exit status and the tail of its output. 2: usage error.
set -euo pipefail

usage() { echo "usage: $0 TOOLS_DIR WORK_DIR [PAGE.md ...]" >&2; exit 2; }
[[ $# -ge 2 ]] || usage
TOOLS_DIR=$1
WORK_DIR=$2
shift 2
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
LIST=$HERE/pages.txt
fail() { echo "readme_commands: FAIL: $*" >&2; exit 1; }

# The pages, as absolute paths.
pages=()
if (($#)); then
    for p in "$@"; do
        [[ -f $p ]] || fail "$p not found"
        pages+=("$(cd "$(dirname "$p")" && pwd)/$(basename "$p")")
    done
else
    [[ -f $LIST ]] || fail "$LIST not found"
    while IFS= read -r p || [[ -n $p ]]; do
        p=${p%%#*}
        p=${p//[[:space:]]/}
        [[ -n $p ]] || continue
        [[ -f $ROOT/$p ]] || fail "$LIST names $p, which is not in $ROOT"
        pages+=("$ROOT/$p")
    done <"$LIST"
fi
((${#pages[@]})) || fail "no pages to run"
# A page's name in messages: its path in the checkout, else as given.
pname() { if [[ $1 == "$ROOT"/* ]]; then echo "${1#"$ROOT"/}"; else echo "$1"; fi; }
[[ -d $TOOLS_DIR ]] || fail "TOOLS_DIR $TOOLS_DIR is not a directory"
TOOLS_DIR=$(cd "$TOOLS_DIR" && pwd)

# Each tool's directory, first on PATH.
TOOL_PATH=
for tool in nebgen nebillum nebphase nebpyramid nebscatter nebrender nebtone nebimport nebexport; do
    found=
    for exe in "$TOOLS_DIR/$tool" "$TOOLS_DIR/$tool/$tool" "$TOOLS_DIR/../$tool/$tool"; do
        if [[ -f $exe && -x $exe ]]; then found=$exe; break; fi
    done
    [[ -n $found ]] || fail "no executable $tool in $TOOLS_DIR (looked for $TOOLS_DIR/$tool, $TOOLS_DIR/$tool/$tool, $TOOLS_DIR/../$tool/$tool): build the tools first (make -f Makefile.data tools)"
    dir=$(cd "$(dirname "$found")" && pwd)
    case ":$TOOL_PATH:" in *":$dir:"*) ;; *) TOOL_PATH=${TOOL_PATH:+$TOOL_PATH:}$dir ;; esac
done
export PATH=$TOOL_PATH:$PATH
# The pages' python3 is Debian's, with the packages the Makefile installs (numpy, astropy,
# h5py, matplotlib). Where another python3 comes first on PATH (a virtual environment, pyenv)
# and lacks them, Debian's runs the pages' python3 commands.
if ! python3 -c 'import numpy, astropy' 2>/dev/null && /usr/bin/python3 -c 'import numpy, astropy' 2>/dev/null; then
    shim=$(mktemp -d)
    trap 'rm -rf "$shim"' EXIT
    ln -s /usr/bin/python3 "$shim/python3"
    export PATH=$shim:$PATH
fi

# The commands of one page: "LINE<TAB>COMMAND" records, NUL-separated (a command keeps its
# continuation lines, joined with newlines, so the shell sees what the page shows); on
# stderr "blocks N skipped M", its sh/bash blocks and how many of them are marked skip.
extract() {
    awk '
    function flush() { if (cmd != "") printf "%d\t%s%c", start, cmd, 0; cmd = "" }
    /^[ \t]*```/ {
        if (!infence) {
            infence = 1
            lang = $0; sub(/^[ \t]*```[ \t]*/, "", lang); sub(/[ \t].*/, "", lang)
            run = (lang == "sh" || lang == "bash") && !skip
            nblocks += (lang == "sh" || lang == "bash"); nskipped += (lang == "sh" || lang == "bash") && skip
            skip = 0
        } else {
            if (run) flush()
            infence = 0; run = 0
        }
        next
    }
    infence {
        if (!run) next
        if (cmd == "") {
            if ($0 ~ /^[ \t]*(#|$)/) next
            start = NR; cmd = $0
        } else cmd = cmd "\n" $0
        if ($0 !~ /\\$/) flush()
        next
    }
    /^[ \t]*<!--[ \t]*readme-test:[ \t]*skip/ { skip = 1; next }
    /^[ \t]*$/ { next }
    { skip = 0 }
    END {
        if (infence) { print "readme_commands: unterminated code block" > "/dev/stderr"; exit 1 }
        printf "blocks %d skipped %d\n", nblocks + 0, nskipped + 0 > "/dev/stderr"
    }' "$1"
}

# With the default list: every page of README.md and docs/ with a block to run is listed.
if ((!$#)); then
    while IFS= read -r -d '' page; do
        listed=
        for p in "${pages[@]}"; do [[ $p == "$page" ]] && { listed=1; break; }; done
        [[ -z $listed ]] || continue
        counts=$(extract "$page" 2>&1 >/dev/null) || fail "$(pname "$page"): $counts"
        read -r _ nb _ ns <<<"$counts"
        ((nb == ns)) || fail "$(pname "$page") has $((nb - ns)) sh block(s) to run but is not listed in tests/readme/pages.txt: add it there, at the place its examples belong in the order, or mark each block <!-- readme-test: skip (why) -->"
    done < <(find "$ROOT/README.md" "$ROOT/docs" -name '*.md' -type f -print0 2>/dev/null | sort -z)
fi

mkdir -p "$WORK_DIR" || fail "cannot create $WORK_DIR"
WORK_DIR=$(cd "$WORK_DIR" && pwd)
if [[ -e $WORK_DIR/.readme-test ]]; then
    find "$WORK_DIR" -mindepth 1 -delete
elif [[ -n $(ls -A "$WORK_DIR") ]]; then
    fail "$WORK_DIR is not empty and not an earlier run's folder (no .readme-test): give an empty or new folder"
fi
: >"$WORK_DIR/.readme-test"
# The pages speak from the top of a checkout: its examples/ folder (camera paths) is there.
ln -s "$ROOT/examples" "$WORK_DIR/examples"
LOGS=$WORK_DIR/.readme-test-logs
mkdir -p "$LOGS"

# Every page's commands, in page order: "PAGE<TAB>LINE<TAB>COMMAND" (PAGE: its index).
commands=()
blocks=0
skipped=0
for i in "${!pages[@]}"; do
    page=${pages[$i]}
    n0=${#commands[@]}
    while IFS= read -r -d '' rec; do commands+=("$i"$'\t'"$rec"); done < <(extract "$page" 2>"$LOGS/extract.err")
    grep -q '^blocks ' "$LOGS/extract.err" || fail "$(pname "$page"): $(cat "$LOGS/extract.err")"
    read -r _ nb _ ns <"$LOGS/extract.err"
    blocks=$((blocks + nb))
    skipped=$((skipped + ns))
    echo "$(pname "$page"): blocks $nb skipped $ns, $((${#commands[@]} - n0)) commands"
done
echo "blocks $blocks skipped $skipped"
((${#commands[@]})) || fail "no commands found in ${pages[*]}"
echo "readme_commands: ${#commands[@]} commands from ${#pages[@]} page(s), in $WORK_DIR, tools from $TOOL_PATH"

cd "$WORK_DIR"
n=0
T0=$(date +%s%N)
for rec in "${commands[@]}"; do
    i=${rec%%$'\t'*}
    rec=${rec#*$'\t'}
    line=${rec%%$'\t'*}
    cmd=${rec#*$'\t'}
    where=$(pname "${pages[$i]}"):$line
    n=$((n + 1))
    t0=$(date +%s%N)
    status=0
    bash -euo pipefail -c "$cmd" </dev/null >"$LOGS/$n.log" 2>&1 || status=$?
    secs=$(awk -v ns=$(($(date +%s%N) - t0)) 'BEGIN { printf "%.1f", ns / 1e9 }')
    first=${cmd%%$'\n'*}
    if ((status != 0)); then
        echo "FAILED $where (exit $status, ${secs} s): $first" >&2
        [[ $cmd == "$first" ]] || echo "  (the whole command: $cmd)" >&2
        echo "  its output (last 20 lines):" >&2
        tail -n 20 "$LOGS/$n.log" | sed 's/^/    /' >&2
        fail "$where: $first"
    fi
    printf 'ok %5s s  %-30s %s\n' "$secs" "$where" "$first"
done
echo "readme_commands: PASS: all ${#commands[@]} commands ran, $(awk -v ns=$(($(date +%s%N) - T0)) 'BEGIN { printf "%.0f", ns / 1e9 }') s"
