# SPDX-License-Identifier: Apache-2.0
# shellcheck shell=bash
# Shared by the bench/*.sh scripts (source it after setting SCRIPT, the name for messages):
# checks, a temporary working folder, and commands timed with /usr/bin/time -v.

TIME=/usr/bin/time

# bench_require EXE...: fails unless every EXE is executable.
bench_require() {
    local exe
    for exe in "$@"; do
        [[ -x $exe ]] || { echo "$SCRIPT: error: $exe not found or not executable" >&2; exit 1; }
    done
}

# bench_install_debs PKG...: installs those of the Debian packages PKG that are missing, with
# apt-get (as root, else through sudo), as Makefile.data's install_missing does; quick when none
# are. BENCH_INSTALL=0 names them instead. Fails with one line naming the packages if they
# cannot be installed. Without dpkg-query (not Debian) it does nothing: later checks report.
bench_install_debs() {
    command -v dpkg-query >/dev/null || return 0
    local p missing=() sudo=()
    for p in "$@"; do
        dpkg-query -W -f='${Status}\n' "$p" 2>/dev/null | grep -q 'install ok installed' ||
            missing+=("$p")
    done
    ((${#missing[@]})) || return 0
    if [[ ${BENCH_INSTALL:-1} == 0 ]]; then
        echo "$SCRIPT: error: missing Debian packages: ${missing[*]} (apt-get install ${missing[*]}; BENCH_INSTALL=0 stopped me installing them)" >&2
        exit 1
    fi
    if [[ $(id -u) != 0 ]]; then
        command -v sudo >/dev/null || {
            echo "$SCRIPT: error: missing Debian packages: ${missing[*]}; run as root or install them: apt-get install ${missing[*]}" >&2
            exit 1
        }
        sudo=(sudo)
    fi
    echo "$SCRIPT: installing Debian packages: ${missing[*]}" >&2
    if ! { "${sudo[@]}" apt-get update -qq &&
           "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
               --no-install-recommends "${missing[@]}"; } >&2; then
        echo "$SCRIPT: error: could not install the Debian packages ${missing[*]} (apt-get install ${missing[*]})" >&2
        exit 1
    fi
}

# bench_tmpdir: cd into a new temporary folder, removed on exit unless KEEP=1.
bench_tmpdir() {
    TMP=$(mktemp -d "${TMPDIR:-/tmp}/nebula-bench.XXXXXX")
    trap 'if [[ ${KEEP:-0} == 1 ]]; then echo "kept $TMP" >&2; else rm -rf "$TMP"; fi' EXIT
    cd "$TMP" || exit 1
}

# timed NAME CMD...: runs CMD under /usr/bin/time -v; its stdout and stderr go to NAME.log,
# the resource report to NAME.time. Fails the script, showing the log, if CMD fails.
timed() {
    local name=$1; shift
    if ! "$TIME" -v -o "$name.time" "$@" >"$name.log" 2>&1; then
        echo "$SCRIPT: error: '$*' failed:" >&2
        cat "$name.log" >&2
        exit 1
    fi
}

# Readers of NAME.time: wall-clock seconds, CPU seconds (user + system), peak RSS [kB].
wall()   { awk -F': ' '/Elapsed \(wall clock\)/ { n = split($2, p, ":"); s = 0;
                          for (i = 1; i <= n; ++i) s = s * 60 + p[i]; print s }' "$1.time"; }
cpu()    { awk -F': ' '/User time/ { u = $2 } /System time/ { s = $2 } END { print u + s }' "$1.time"; }
maxrss() { awk -F': ' '/Maximum resident set size/ { print $2 }' "$1.time"; }
