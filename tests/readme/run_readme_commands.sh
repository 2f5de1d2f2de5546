#!/usr/bin/env bash
# Runs the shell commands of the README's examples, in order, as a new user would type them.
#
#   run_readme_commands.sh TOOLS_DIR WORK_DIR [README]
#
# TOOLS_DIR: where the tools are, either as TOOLS_DIR/<tool> or as TOOLS_DIR/<tool>/<tool>
# (CTest passes $<TARGET_FILE_DIR:nebgen>, so TOOLS_DIR/../<tool>/<tool> is looked at too);
# they are put first on PATH, so the README's plain `nebgen ...` runs them. WORK_DIR is
# created if needed and the commands run in it; a WORK_DIR left by an earlier run (it holds
# .readme-test) is emptied first, any other non-empty one is refused. README defaults to the
# project's README.md.
#
# What runs: every line of every ```sh or ```bash block (a line ending in \ continues on the
# next), each with `bash -euo pipefail` in WORK_DIR, in README order, so later examples use
# the files earlier ones made. Blank lines and comment lines are not commands. A block is left
# out only when the README says so: the line before its opening fence (blank lines between
# allowed) is an HTML comment starting `<!-- readme-test: skip` (invisible on the rendered
# page; say why in it), for blocks that install packages, build the project, run minutes-long
# renders or benchmarks, or need Blender or files the README does not make. Nothing is resized
# here: the README's examples are kept small enough to run in seconds.
#
# Exit 0 when every command succeeded; otherwise 1, naming the README line of the first
# command that failed, with its exit status and the tail of its output. 2: usage error.
set -euo pipefail

usage() { echo "usage: $0 TOOLS_DIR WORK_DIR [README]" >&2; exit 2; }
[[ $# -eq 2 || $# -eq 3 ]] || usage
TOOLS_DIR=$1
WORK_DIR=$2
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
README=${3:-$HERE/../../README.md}
fail() { echo "readme_commands: FAIL: $*" >&2; exit 1; }

[[ -f $README ]] || fail "$README not found"
README=$(cd "$(dirname "$README")" && pwd)/$(basename "$README")
RNAME=${README##*/}
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
# The README's python3 is Debian's, with the packages the Makefile installs (numpy, astropy,
# h5py, matplotlib). Where another python3 comes first on PATH (a virtual environment, pyenv)
# and lacks them, Debian's runs the README's python3 commands.
if ! python3 -c 'import numpy, astropy' 2>/dev/null && /usr/bin/python3 -c 'import numpy, astropy' 2>/dev/null; then
    shim=$(mktemp -d)
    trap 'rm -rf "$shim"' EXIT
    ln -s /usr/bin/python3 "$shim/python3"
    export PATH=$shim:$PATH
fi

mkdir -p "$WORK_DIR" || fail "cannot create $WORK_DIR"
WORK_DIR=$(cd "$WORK_DIR" && pwd)
if [[ -e $WORK_DIR/.readme-test ]]; then
    find "$WORK_DIR" -mindepth 1 -delete
elif [[ -n $(ls -A "$WORK_DIR") ]]; then
    fail "$WORK_DIR is not empty and not an earlier run's folder (no .readme-test): give an empty or new folder"
fi
: >"$WORK_DIR/.readme-test"
# The README speaks from the top of a checkout: its examples/ folder (camera paths) is there.
ln -s "$(dirname "$README")/examples" "$WORK_DIR/examples"
LOGS=$WORK_DIR/.readme-test-logs
mkdir -p "$LOGS"

# The commands: "LINE<TAB>COMMAND" records, NUL-separated (a command keeps its continuation
# lines, joined with newlines, so the shell sees what the README shows).
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
        printf "blocks %d skipped %d\n", nblocks, nskipped > "/dev/stderr"
    }' "$README"
}

commands=()
while IFS= read -r -d '' rec; do commands+=("$rec"); done < <(extract 2>"$LOGS/extract.err")
cat "$LOGS/extract.err"
((${#commands[@]})) || fail "no commands found in $README"
echo "readme_commands: ${#commands[@]} commands from $README, in $WORK_DIR, tools from $TOOL_PATH"

cd "$WORK_DIR"
n=0
T0=$(date +%s%N)
for rec in "${commands[@]}"; do
    line=${rec%%$'\t'*}
    cmd=${rec#*$'\t'}
    n=$((n + 1))
    t0=$(date +%s%N)
    status=0
    bash -euo pipefail -c "$cmd" </dev/null >"$LOGS/$n.log" 2>&1 || status=$?
    secs=$(awk -v ns=$(($(date +%s%N) - t0)) 'BEGIN { printf "%.1f", ns / 1e9 }')
    first=${cmd%%$'\n'*}
    if ((status != 0)); then
        echo "FAILED $RNAME:$line (exit $status, ${secs} s): $first" >&2
        [[ $cmd == "$first" ]] || echo "  (the whole command: $cmd)" >&2
        echo "  its output (last 20 lines):" >&2
        tail -n 20 "$LOGS/$n.log" | sed 's/^/    /' >&2
        fail "$RNAME line $line: $first"
    fi
    printf 'ok %5s s  %s:%-4s %s\n' "$secs" "$RNAME" "$line" "$first"
done
echo "readme_commands: PASS: all ${#commands[@]} commands ran, $(awk -v ns=$(($(date +%s%N) - T0)) 'BEGIN { printf "%.0f", ns / 1e9 }') s"
