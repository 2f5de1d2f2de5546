#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Single scattering next to an embedded star (DESIGN §3.5), with two builds of nebula:
#
#   bench/embedded_star.sh BEFORE_BUILD AFTER_BUILD
#
# 1. The calibrated sphere: tests/fits/test_fits.py's thin shell (96^3 voxels of 0.05 pc,
#    n_H 0.1 cm^-3 out to 2.2 pc, a 10^3 L_sun 10^4 K star at the centre, on the corner of
#    eight voxels; orthographic from 1 kpc, 128x128 pixels of 0.04 pc, nebrender --fits)
#    filled to the star (R1 = 0) and with a cavity r < 0.3 pc: the SCATTERED flux over its
#    closed form a k (R2 - R1) L_nu / (4 pi D^2) at the three wavelengths.
# 2. Scenes whose stars are not embedded: bench/error_table.sh's five 64^3 scenes (the
#    example's two stars in nebgen's default 0.6 pc cavities; side: one star 9 pc to the
#    side), single scattering, 96x96: the flux of AFTER against BEFORE (whole image).
# 3. The time of a 512x512 single-scattering frame of the 128^3 example, each build (best
#    of 3; the machine is shared, so a ratio, not a speed).
#
# COMPARE=path/to/exr_compare (default AFTER_BUILD/bench/exr_compare); PYTHON=python3 with numpy and astropy.
set -euo pipefail
SCRIPT=embedded_star.sh
here=$(cd "$(dirname "$0")" && pwd)
source "$here/common.sh"
[[ $# -ge 2 ]] || { echo "usage: bench/embedded_star.sh BEFORE_BUILD AFTER_BUILD" >&2; exit 2; }
before=$(cd "$1" && pwd)/tools
after=$(cd "$2" && pwd)/tools
COMPARE=${COMPARE:-$(cd "$2" && pwd)/bench/exr_compare}
bench_require "$before/nebrender" "$after/nebrender" "$after/nebimport" "$after/nebillum" \
    "$after/nebgen" "$COMPARE"
PYTHON=${PYTHON:-python3}
bench_tmpdir

echo "## 1. The calibrated sphere (SCATTERED flux / closed form)"
echo
echo "| build | cavity | 435.8 nm | 546.1 nm | 700 nm |"
echo "|---|---|---|---|---|"
for R1 in 0 0.3; do
    "$PYTHON" - "$R1" <<'EOF'
import sys
import numpy as np
R1 = float(sys.argv[1])
N, hv, R2, n0 = 96, 0.05, 2.2, 0.1
sub = (np.arange(4) + 0.5) / 4
coords = ((np.arange(N)[:, None] + sub[None, :]).ravel() - N / 2) * hv
x2 = coords**2
frac = np.zeros((N, N, N))
for i in range(N * 4):
    r = np.sqrt(x2[i] + x2[:, None] + x2[None, :])
    inside = ((r >= R1) & (r <= R2)).astype(np.float64)
    frac[i // 4] += inside.reshape(N, 4, N, 4).sum(axis=(1, 3))
np.save(f"sphere{sys.argv[1]}.npy", (n0 * frac / 64).astype(np.float32))
EOF
    "$after/nebimport" -i "sphere$R1.npy" --unit cm-3 --voxel-size 0.05pc \
        --star "s:0,0,0:1000:10000" -o "sphere$R1.vdb" > /dev/null
    "$after/nebillum" -i "sphere$R1.vdb" -o "lit$R1.vdb" > /dev/null
    for b in before after; do
        bin=$before
        [[ $b == after ]] && bin=$after
        "$bin/nebrender" -i "lit$R1.vdb" --camera orthographic --eye 0,0,-10 --look-at 0,0,0 \
            --distance 1000 --pixel-size 0.04pc --res 128x128 --sky 83.82,-5.39 \
            -o "$b$R1.exr" --png none --fits "$b$R1.fits" > /dev/null
        "$PYTHON" - "$b$R1.fits" "$b" "$R1" <<'EOF'
import json, math, sys
import numpy as np
from astropy.io import fits
path, build, R1 = sys.argv[1], sys.argv[2], float(sys.argv[3])
hdul = fits.open(path)
h, c, k_B, sigma = 6.62607015e-34, 299792458.0, 1.380649e-23, 5.670374419e-8
L_SUN, PC = 3.828e26, 3.0856775814913673e16
dust = json.loads(hdul[0].header["DUST"])
def ccm89(lam, rv):
    y = 1000.0 / lam - 1.82
    a = (1 + 0.17699 * y - 0.50447 * y**2 - 0.02427 * y**3 + 0.72085 * y**4 + 0.01979 * y**5
         - 0.77530 * y**6 + 0.32999 * y**7)
    b = (1.41338 * y + 2.28305 * y**2 + 1.07233 * y**3 - 5.38434 * y**4 - 0.62251 * y**5
         + 5.30260 * y**6 - 2.09002 * y**7)
    return a + b / rv
def l_nu(L, T, lam_nm):
    lam = lam_nm * 1e-9
    B = 2 * h * c**2 / lam**5 / math.expm1(h * c / (lam * k_B * T))
    return L * L_SUN * math.pi * B / (sigma * T**4) * lam**2 / c
omega = (0.04 / 1000.0) ** 2
out = {}
for hdu in hdul:
    if hdu.name != "SCATTERED":
        continue
    lam = float(hdu.header["WAVELEN"])
    data = hdu.data
    k = dust["kappa_V"] * ccm89(lam, dust.get("R_V", 3.1)) * 0.1
    expected = dust["albedo"] * k * (2.2 - R1) * l_nu(1000.0, 10000.0, lam) / (
        4 * math.pi * (1000.0 * PC) ** 2) / 1e-26
    out[lam] = data.astype(np.float64).sum() * omega * 1e6 / expected
cells = " | ".join(f"{out[l]:.4f}" for l in sorted(out))
print(f"| {build} | {'r < 0.3 pc' if R1 > 0 else 'none'} | {cells} |")
EOF
    done
done

echo
echo "## 2. Stars not embedded: single-scattering flux, AFTER / BEFORE - 1"
echo
echo "| scene | flux change (Y) | R | G | B |"
echo "|---|---|---|---|---|"
for name in thin moderate thick side filaments; do
    case $name in
        thin) gen=(--density 600) ;;
        moderate) gen=(--density 16000) ;;
        thick) gen=(--density 160000) ;;
        side) gen=(--density 16000 --star "side:-9,1.5,0:40000:B1V") ;;
        filaments) gen=(--density 60000 --exponent 3 --contrast 4 --frequency 2.5) ;;
    esac
    "$after/nebgen" --res 64 --emission 0 "${gen[@]}" -o "$name.vdb" > /dev/null
    "$after/nebillum" -i "$name.vdb" -o "$name-lit.vdb" > /dev/null
    for b in before after; do
        bin=$before
        [[ $b == after ]] && bin=$after
        "$bin/nebrender" -i "$name-lit.vdb" --no-stars --res 96x96 -o "$name-$b.exr" \
            --png none > /dev/null
    done
    "$COMPARE" "$name-before.exr" "$name-after.exr" |
        awk -v n="$name" '$1 == "Y" { y = $3 / $2 - 1 } $1 == "R" { r = $3 / $2 - 1 }
            $1 == "G" { g = $3 / $2 - 1 } $1 == "B" { bl = $3 / $2 - 1 }
            END { printf "| %s | %+.4f %% | %+.4f %% | %+.4f %% | %+.4f %% |\n", n, 100 * y,
                  100 * r, 100 * g, 100 * bl }'
done

echo
echo "## 3. A 512x512 single-scattering frame of the 128^3 example (best of 3, shared machine)"
echo
"$after/nebgen" --res 128 -o example.vdb > /dev/null
"$after/nebillum" -i example.vdb -o example-lit.vdb > /dev/null
for b in before after; do
    bin=$before
    [[ $b == after ]] && bin=$after
    best=""
    for _ in 1 2 3; do
        t=$( { /usr/bin/time -f %e "$bin/nebrender" -i example-lit.vdb --res 512x512 \
            -o "example-$b.exr" --png none > /dev/null; } 2>&1 | tail -1)
        best=$(awk -v a="$t" -v b="$best" 'BEGIN { print (b == "" || a < b) ? a : b }')
    done
    echo "- $b: $best s"
done
"$COMPARE" example-before.exr example-after.exr | awk '$1 == "Y" {
    printf "- the example frame, flux change (Y, AFTER / BEFORE - 1): %+.4f %%\n",
        100 * ($3 / $2 - 1) }'
