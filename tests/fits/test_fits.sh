#!/usr/bin/env bash
# nebrender --fits against closed forms and astropy (tests/fits/test_fits.py): the absolute
# calibration of an optically thin shell around a star, the celestial WCS of star sprites,
# the header and the refusals. Skipped (exit 77, with a message) when no python3 has numpy
# and astropy (Debian: python3-numpy python3-astropy).
#
#   test_fits.sh TOOLS_DIR WORK_DIR
set -euo pipefail
[[ $# -eq 2 ]] || { echo "usage: $0 TOOLS_DIR WORK_DIR" >&2; exit 2; }
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
for python in python3 /usr/bin/python3; do
    if "$python" -c 'import numpy, astropy' 2>/dev/null; then
        exec "$python" "$here/test_fits.py" "$1" "$2"
    fi
done
echo "test_fits: SKIP: no python3 with numpy and astropy (python3-numpy python3-astropy)"
exit 77
