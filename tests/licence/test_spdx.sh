#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# cmake/spdx.sh on a scratch git repository of one file per comment style: --check lists every
# source file without the identifier (and no data file) and fails; the add mode puts it where
# each syntax wants it (after a #! line and <!DOCTYPE html>, line 1 otherwise), changes nothing
# else and nothing the second time; then --check passes, and fails again, naming the file, when
# one file loses its line.
#   test_spdx.sh SOURCE_DIR WORK
set -euo pipefail
src=$1 work=$2
spdx=$src/cmake/spdx.sh
fail() {
    echo "FAIL: $*" >&2
    exit 1
}
rm -rf "$work"
mkdir -p "$work/repo/src" "$work/repo/tests/fuzz/corpus/json"
cd "$work/repo"
printf '#pragma once\nint f();\n' > src/f.h
printf 'int f() { return 1; }\n' > src/f.cpp
printf '#!/usr/bin/env bash\necho hi\n' > run.sh
printf '"""A module."""\nprint(1)\n' > mod.py
printf '#!/bin/bash\n#SBATCH --ntasks=1\nsrun true\n' > job.sbatch
printf '#!/usr/bin/env bash\ntrue\n' > runner # no extension: a #! line makes it a script
printf 'cmake_minimum_required(VERSION 3.18)\n' > CMakeLists.txt
printf 'all:\n\ttrue\n' > Makefile.data
printf '<!DOCTYPE html>\n<html></html>\n' > page.html
printf '{"a": 1}\n' > data.json
printf '# Title\n' > README.md
printf 'x,y\n1,2\n' > table.csv
printf '{}\n' > tests/fuzz/corpus/json/seed
git init -q .
git add -A
sources=(src/f.h src/f.cpp run.sh mod.py job.sbatch runner CMakeLists.txt Makefile.data page.html)

if "$spdx" --check . > "$work/check1.txt" 2> "$work/check1.err"; then
    fail "--check passed on files without the identifier"
fi
for f in "${sources[@]}"; do
    grep -q "^$f: " "$work/check1.txt" || fail "--check did not list $f"
done
[[ $(wc -l < "$work/check1.txt") -eq ${#sources[@]} ]] ||
    fail "--check listed files it should skip: $(cat "$work/check1.txt")"

"$spdx" .
id="SPDX-License-Identifier: Apache-2.0"
expect() { # FILE LINE TEXT: line LINE of FILE is TEXT
    [[ $(sed -n "$2p" "$1") == "$3" ]] || fail "$1 line $2 is \"$(sed -n "$2p" "$1")\", expected \"$3\""
}
expect src/f.h 1 "// $id"
expect src/f.h 2 "#pragma once"
expect src/f.cpp 1 "// $id"
expect run.sh 1 "#!/usr/bin/env bash"
expect run.sh 2 "# $id"
expect run.sh 3 "echo hi"
expect mod.py 1 "# $id"
expect job.sbatch 2 "# $id"
expect job.sbatch 3 "#SBATCH --ntasks=1"
expect runner 2 "# $id"
expect CMakeLists.txt 1 "# $id"
expect Makefile.data 1 "# $id"
expect page.html 1 "<!DOCTYPE html>"
expect page.html 2 "<!-- $id -->"
[[ $(git diff --numstat | awk '$1 != 1 || $2 != 0' | wc -l) -eq 0 ]] ||
    fail "the add mode changed more than one added line per file: $(git diff --numstat)"
[[ -z $(git diff --name-only -- data.json README.md table.csv tests) ]] || fail "a data file was changed"

git add -A
"$spdx" .
[[ -z $(git diff --name-only) ]] || fail "a second run changed $(git diff --name-only)"
"$spdx" --check . > "$work/check2.txt" || fail "--check failed after the add mode: $(cat "$work/check2.txt")"

sed -i 2d run.sh
if "$spdx" --check . > "$work/check3.txt" 2>&1; then
    fail "--check passed with run.sh's identifier removed"
fi
grep -q "^run.sh: " "$work/check3.txt" || fail "--check did not name run.sh: $(cat "$work/check3.txt")"
echo "spdx: --check lists what lacks the identifier; the add mode puts it in place, once"
