#!/usr/bin/env bash
# nebimport and nebexport against the programs whose files they read and write: cubes written
# by astropy (FITS), h5py (HDF5) and numpy (.npy), imported, exported back and compared
# (tests/import/test_import.py). Skipped (exit 77, with a message) when no python3 has numpy,
# astropy and h5py (Debian: python3-numpy python3-astropy python3-h5py).
#
#   test_import.sh TOOLS_DIR WORK_DIR
set -euo pipefail
[[ $# -eq 2 ]] || { echo "usage: $0 TOOLS_DIR WORK_DIR" >&2; exit 2; }
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
for python in python3 /usr/bin/python3; do
    if "$python" -c 'import numpy, astropy, h5py' 2>/dev/null; then
        exec "$python" "$here/test_import.py" "$1" "$2"
    fi
done
echo "test_import: SKIP: no python3 with numpy, astropy and h5py (python3-numpy python3-astropy python3-h5py)"
exit 77
