#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# SPDX licence identifiers (nebula is Apache-2.0: LICENSE) in every tracked source file.
#
#   cmake/spdx.sh [ROOT]           adds the identifier where it is missing (files edited in place)
#   cmake/spdx.sh --check [ROOT]   lists the files that lack it; exits 1 if any (ctest spdx_headers)
#
# ROOT: a git checkout (default: the one this script is in); its tracked files (git ls-files)
# are the ones considered. The identifier goes where each syntax allows a comment first:
#   C and C++ (.cpp .h .hpp .cc .c)                   // SPDX-License-Identifier: Apache-2.0  (line 1)
#   shell, Python, sbatch, any file with a #! line    # SPDX-...  (line 2 after a #! line, else 1)
#   CMake (CMakeLists.txt, .cmake, .cmake.in), nebula.pc.in, Makefile.data, .clang-format,
#   .gitignore, sanitizer lists (.supp, sanitizer_ignorelist.txt), tests/readme/pages.txt
#                                                     # SPDX-...  (line 1)
#   HTML (nebview's page)                             <!-- SPDX-... -->  (after <!DOCTYPE html>)
# Left out: data and documents (Markdown, JSON, CSV, PNG, SVG, VDB, HDF5, FITS, gzip, the
# fuzzers' corpus and regressions), LICENSE and cmake/debian-copyright (the licence itself).
# Exit: 0 done (or nothing missing), 1 files lack it (--check), 2 bad use, 77 ROOT is not a
# git checkout (nothing to list; ctest skips).
set -euo pipefail
ID="SPDX-License-Identifier: Apache-2.0"
check=0
if [[ ${1:-} == --check ]]; then
    check=1
    shift
fi
[[ $# -le 1 && ${1:-} != -* ]] || {
    echo "usage: cmake/spdx.sh [--check] [ROOT]" >&2
    exit 2
}
root=${1:-$(dirname "$0")/..}
cd "$root" || exit 2
git rev-parse --is-inside-work-tree > /dev/null 2>&1 || {
    echo "spdx: $root is not a git checkout: no tracked files to check" >&2
    exit 77
}

# The first two lines of file $1, in l1 and l2 (builtins only: no process per file).
read_head() {
    l1="" l2=""
    { IFS= read -r l1 || true; IFS= read -r l2 || true; } < "$1"
}

# The comment style of tracked file $1 (its first line in l1), in style: cpp, hash, html or skip.
style_of() {
    case $1 in
    LICENSE | cmake/debian-copyright | tests/fuzz/corpus/* | tests/fuzz/regressions/* | \
        tests/fuzz/libhdf5/*) style=skip ;;
    *.cpp | *.h | *.hpp | *.cc | *.c) style=cpp ;;
    *.sh | *.py | *.sbatch) style=hash ;;
    CMakeLists.txt | */CMakeLists.txt | *.cmake | *.cmake.in | *.pc.in | Makefile.data | \
        .clang-format | .gitignore | *.supp | tests/sanitizer_ignorelist.txt | \
        tests/readme/pages.txt) style=hash ;;
    *.html) style=html ;;
    *.md | *.json | *.csv | *.png | *.svg | *.vdb | *.h5 | *.fits | *.gz | *.txt) style=skip ;;
    *) [[ $l1 == "#!"* ]] && style=hash || style=skip ;;
    esac
}

# Where the identifier goes in a file of $style whose first line is l1 (line: 1, or 2 after a
# #! or <!DOCTYPE line), and the comment that holds it.
place_of() {
    line=1
    case $style in
    cpp) comment="// $ID" ;;
    hash)
        comment="# $ID"
        [[ $l1 != "#!"* ]] || line=2
        ;;
    html)
        comment="<!-- $ID -->"
        [[ ${l1,,} != "<!doctype"* ]] || line=2
        ;;
    esac
}

missing=0
while IFS= read -r -d '' file; do
    [[ -f $file && ! -L $file ]] || continue # a submodule, a link, a file deleted but not staged
    case $file in *.png | *.vdb | *.h5 | *.fits | *.gz | tests/fuzz/*/*) continue ;; esac
    read_head "$file"
    style_of "$file"
    [[ $style != skip ]] || continue
    place_of
    present=$l1
    ((line == 1)) || present=$l2
    [[ ${present%$'\r'} != "$comment" ]] || continue
    if ((check)); then
        echo "$file: no \"$comment\" on line $line"
        missing=$((missing + 1))
    elif [[ ! -s $file ]]; then
        printf '%s\n' "$comment" > "$file"
    elif ((line == 1)); then
        sed -i "1i\\$comment" "$file"
    else
        sed -i "1a\\$comment" "$file"
    fi
done < <(git ls-files -z)

if ((check)); then
    if ((missing)); then
        echo "spdx: $missing tracked source files lack the identifier; cmake/spdx.sh adds it" >&2
        exit 1
    fi
    echo "spdx: every tracked source file has \"$ID\""
fi
