#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# nebview in a real browser (tests/view/test_browser.py) on a small example made here: the
# reflection preset at 64^3, lit, with nebscatter's field (few packets: the test looks at the
# viewer, not the field's noise). Skipped (exit 77, with a message) without Chromium,
# chromedriver or Selenium.
# Usage: run_browser_test.sh TOOLS_DIR WORK_DIR
set -euo pipefail
tools=$1
work=$2
src=$(cd "$(dirname "$0")" && pwd)
rm -rf "$work"
mkdir -p "$work"
"$tools/nebgen" --preset reflection --res 64 --seed 1 -o "$work/nebula.vdb"
"$tools/nebillum" -i "$work/nebula.vdb" -o "$work/lit.vdb"
"$tools/nebscatter" -i "$work/lit.vdb" --packets 100000 -o "$work/scattered.vdb"
python=python3
[ -x /usr/bin/python3 ] && python=/usr/bin/python3 # Debian's, with python3-selenium
exec "$python" "$src/test_browser.py" "$tools/nebview" "$tools/nebrender" "$work/scattered.vdb" \
    "$work/browser"
