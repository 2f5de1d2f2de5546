#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# nebimport's speed and peak memory on a 512^3 float32 FITS cube (a sparse-ish cloud: a few
# Gaussian clumps with noise, values below 5 cm^-3 clipped to 0), made on
# the fly with numpy + astropy in a temporary folder that is deleted afterwards.
# Targets (issue 25): at most 20 s, and a peak RSS of at most 1.5x the cube (768 MiB).
#
#   bench/import_speed.sh [BUILD] [N]     (defaults: build, 512)
#   DENSE=1 bench/import_speed.sh ...      every voxel non-zero: the grid's worst case
set -euo pipefail
build=${1:-build}
n=${2:-512}
tool=$(cd "$build/tools" && pwd)/nebimport
[[ -x $tool ]] || { echo "no $tool: build nebimport first" >&2; exit 1; }
python=
for p in python3 /usr/bin/python3; do
    if "$p" -c 'import numpy, astropy' 2>/dev/null; then python=$p; break; fi
done
[[ -n $python ]] || { echo "needs python3 with numpy and astropy (python3-numpy python3-astropy)" >&2; exit 1; }
[[ -x /usr/bin/time ]] || { echo "needs /usr/bin/time (Debian: time)" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

"$python" - "$work/cube.fits" "$n" "${DENSE:-0}" <<'PY'
import sys
import numpy as np
from astropy.io import fits
path, n, dense = sys.argv[1], int(sys.argv[2]), sys.argv[3] == "1"
rng = np.random.default_rng(25)
centres = rng.uniform(0.2 * n, 0.8 * n, size=(12, 3))
widths = rng.uniform(0.04 * n, 0.12 * n, size=12)
peaks = rng.uniform(50, 500, size=12)
# FITS order: data[z, y, x], written one z slab at a time (float32 throughout).
header = fits.Header()
header['SIMPLE'] = True
header['BITPIX'] = -32
header['NAXIS'] = 3
for i in (1, 2, 3):
    header[f'NAXIS{i}'] = n
header['BUNIT'] = 'cm-3'
for i in (1, 2, 3):
    header[f'CTYPE{i}'] = 'XYZ'[i - 1]
    header[f'CUNIT{i}'] = 'pc'
    header[f'CDELT{i}'] = 0.01
    header[f'CRPIX{i}'] = (n + 1) / 2
    header[f'CRVAL{i}'] = 0.0
header.tofile(path, overwrite=True)
y, x = np.mgrid[0:n, 0:n].astype(np.float32)
with open(path, 'ab') as f:
    for z in range(n):
        plane = np.zeros((n, n), np.float32)
        for c, w, p in zip(centres, widths, peaks):
            dz = (z - c[2]) ** 2
            if dz > (3 * w) ** 2:
                continue
            plane += np.float32(p) * np.exp(-((x - c[0]) ** 2 + (y - c[1]) ** 2 + dz) / np.float32(2 * w * w))
        plane += rng.normal(0, 1, size=(n, n)).astype(np.float32)
        if dense:
            plane = np.abs(plane) + np.float32(1)
        else:
            plane[plane < 5] = 0
        f.write(plane.astype('>f4').tobytes())
    pad = (-(n * n * n * 4)) % 2880
    f.write(b'\0' * pad)
PY
cube_mib=$((n * n * n * 4 / 1048576))
echo "cube: ${n}^3 float32 = ${cube_mib} MiB ($(du -m "$work/cube.fits" | cut -f1) MiB file)"
# Cold and warm page cache alike: the file was just written, so it is cached.
/usr/bin/time -v "$tool" -i "$work/cube.fits" -o "$work/nebula.vdb" -v 2> "$work/time.txt" ||
    { cat "$work/time.txt" >&2; exit 1; }
grep -E "nebimport:" "$work/time.txt" || true
wall=$(grep "Elapsed (wall clock)" "$work/time.txt" | awk '{print $NF}')
rss=$(grep "Maximum resident set size" "$work/time.txt" | awk '{print $NF}')
rss_mib=$((rss / 1024))
echo "nebimport: wall ${wall}, peak RSS ${rss_mib} MiB ($(awk -v r="$rss_mib" -v c="$cube_mib" 'BEGIN { printf "%.2f", r / c }')x the cube), output $(du -m "$work/nebula.vdb" | cut -f1) MiB"
