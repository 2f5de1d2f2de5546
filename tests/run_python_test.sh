#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Runs a Python test of the tools (tests/import, tests/fits) with the first python3 that has
# its modules: the one on PATH, else Debian's /usr/bin/python3 (a virtual environment or pyenv
# may come first on PATH without them). Skipped (exit 77, with a message naming the Debian
# packages) when neither has them.
#
#   run_python_test.sh MODULES SCRIPT.py TOOLS_DIR WORK_DIR
#   (MODULES: comma-separated, e.g. numpy,astropy,h5py)
set -euo pipefail
[[ $# -eq 4 ]] || { echo "usage: $0 MODULES SCRIPT.py TOOLS_DIR WORK_DIR" >&2; exit 2; }
modules=$1 script=$2
for python in python3 /usr/bin/python3; do
    if "$python" -c "import ${modules}" 2>/dev/null; then
        exec "$python" "$script" "$3" "$4"
    fi
done
packages=$(printf 'python3-%s ' ${modules//,/ })
echo "$(basename "$script" .py): SKIP: no python3 with ${modules//,/, } (Debian: ${packages% })"
exit 77
