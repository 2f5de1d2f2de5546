#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# nebionize's benchmarks (DESIGN §15, docs/accuracy.md#photoionisation):
#   stromgren  the Strömgren sphere (uniform n_H = 100 cm^-3, Q = 1e49 s^-1, T = 10^4 K, pure
#              hydrogen) at 20 voxels a radius: the front radius against the closed form;
#   photons    the grid's recombinations / Q in a clumpy lognormal field and for two
#              overlapping stars (uniform gas), fronts inside the grid;
#   lexington  the Lexington HII40 model (Ferland 1995; Pequignot et al. 2001): n_H = 100
#              outside a 3e18 cm cavity, a 40 kK black body of Q = 4.26e49 s^-1, 10 pc box at
#              128^3: L(H-beta), the ionised radius and [O III] 5007+4959 / H-beta against the
#              codes' published mean (Ercolano et al. 2003 Table 4), with T_e from the thermal
#              balance (the default; its mean against the codes' <T[NpNe]> ~ 7700-8000 K), at
#              8000 K and at 10^4 K;
#   lineflux   nebrender --spectral --fits of the Strömgren sphere at 1 kpc: the H-alpha band's
#              flux against Q (alpha_eff(H-alpha) / alpha_B) h nu / (4 pi D^2);
#   frontnoise a dense tilted plane front seen face-on: the sight lines' glow about their
#              local mean, at ray spacings 0.5, 0.25, 0.125 (the front voxels' sampling noise);
#   cost       wall time and peak memory of nebionize on the pillars preset (its 3 O stars) at
#              128^3 and 512^3 (RES="128 512 1024" to add 1024^3).
# Usage: bench/ionization.sh [BUILD] [PARTS...]   (BUILD defaults to build; PARTS to all)
set -euo pipefail
SCRIPT=ionization.sh
cd "$(dirname "$0")/.."
# shellcheck source=bench/common.sh
source bench/common.sh
BUILD=$(realpath "${1:-build}")
shift || true
PARTS=${*:-stromgren photons lexington lineflux frontnoise cost}
T=$BUILD/tools
PY=/usr/bin/python3
bench_require "$T/nebionize" "$T/nebimport" "$T/nebexport" "$T/nebgen" "$T/nebillum" "$T/nebrender"
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
cd "$WORK"

star() { # NAME X Y Z Q [T]
    printf '[{"name":"%s","position":[%s,%s,%s],"luminosity":1e5,"temperature":%s,"Q":%s}]' \
        "$1" "$2" "$3" "$4" "${6:-40000}" "$5"
}

ratio_line() { grep -o 'recombinations in the grid / photons: [0-9.e+-]*' | awk '{print $NF}'; }

for part in $PARTS; do
case $part in
stromgren)
    # R_S = 3.1539 pc; 48^3 voxels of R_S / 20.
    $PY -c "import numpy as np; np.save('u.npy', np.full((48,48,48), 100, np.float32))"
    "$T/nebimport" -i u.npy --unit cm-3 --voxel-size 0.157697pc -o u.vdb
    "$T/nebionize" -i u.vdb --stars <(star s 0 0 0 1e49) --abundances he=0 \
        --electron-temperature 10000 --no-dust-absorption -o s.vdb
    "$T/nebexport" -i s.vdb --grid ionization.hii -o hii.npy
    $PY - <<'EOF'
import numpy as np
x = np.load('hii.npy'); h = 0.157697; pc = 3.0856775814913673e18
RS = (3 * 1e49 / (4 * np.pi * 1e4 * 2.59e-13)) ** (1 / 3) / pc
R = (3 * x.sum() * h ** 3 / (4 * np.pi)) ** (1 / 3)
c = np.array(x.shape) // 2
row = x[c[0], c[1], c[2]:]  # from the centre outwards along the last axis
edge = (np.argmin(row > 0.5) - 0.5 + (row[np.argmin(row > 0.5) - 1] - 0.5)) * h
print(f"stromgren: R_S {RS:.4f} pc; ionised volume's radius {R:.4f} pc ({100*(R/RS-1):+.3f} %); "
      f"front voxels {int(((x > 0) & (x < 1)).sum())}")
EOF
    ;;
photons)
    $PY - <<'EOF'
import numpy as np
rng = np.random.default_rng(1); N = 64
k = np.fft.fftfreq(N); K = np.sqrt(k[:, None, None]**2 + k[None, :, None]**2 + k[None, None, :]**2)
K[0, 0, 0] = 1
f = np.real(np.fft.ifftn(np.fft.fftn(rng.normal(size=(N, N, N))) * K ** -1.8)); f /= f.std()
np.save('clumpy.npy', (100 * np.exp(f - 0.5)).astype(np.float32))
np.save('flat.npy', np.full((N, N, N), 100, np.float32))
EOF
    "$T/nebimport" -i clumpy.npy --unit cm-3 --voxel-size 0.15pc -o clumpy.vdb
    "$T/nebimport" -i flat.npy --unit cm-3 --voxel-size 0.12pc -o flat.vdb
    c=$("$T/nebionize" -i clumpy.vdb --stars <(star s 0 0 0 1e48) --abundances he=0 \
        --no-dust-absorption -v -o c.vdb 2>&1 | ratio_line)
    two='[{"name":"a","position":[-0.9,0,0],"luminosity":1e5,"temperature":40000,"Q":1.5e48},
          {"name":"b","position":[0.9,0,0],"luminosity":1e5,"temperature":40000,"Q":1e48}]'
    t=$("$T/nebionize" -i flat.vdb --stars <(echo "$two") --abundances he=0 --no-dust-absorption \
        -v -o t.vdb 2>&1 | ratio_line)
    echo "photons: recombinations / Q: clumpy lognormal field (sigma ln n = 1, 64^3) $c; two overlapping stars $t"
    ;;
lexington)
    $PY - <<'EOF'
import numpy as np
N = 128; h = 10.0 / N; pc = 3.0856775814913673e18
c = (np.arange(N) - (N - 1) / 2) * h
r = np.sqrt(c[:, None, None]**2 + c[None, :, None]**2 + c[None, None, :]**2)
np.save('lex.npy', np.where(r * pc < 3e18, 0, 100).astype(np.float32))
EOF
    "$T/nebimport" -i lex.npy --unit cm-3 --voxel-size 0.078125pc -o lex.vdb
    for te in thermal 8000 10000; do
        topt=(--electron-temperature "$te")
        [ "$te" = thermal ] && topt=()
        /usr/bin/time -f "%e s %M KB" -o lex.time "$T/nebionize" -i lex.vdb \
            --stars <(star s 0 0 0 4.26e49) "${topt[@]}" --no-dust-absorption -v \
            -o lex$te.vdb 2>lex.log
        mean=$(grep -o 'electron temperature: mean [0-9.e+-]*' lex.log | awk '{print $NF}')
        for g in emission emission.oiii ionization.hii; do
            "$T/nebexport" -i lex$te.vdb --grid $g -o "lex$te-$g.npy" --crop none 2>/dev/null ||
                "$T/nebexport" -i lex$te.vdb --grid $g -o "lex$te-$g.npy"
        done
        TE=$te MEAN=$mean $PY - <<'EOF'
import numpy as np, os
name = os.environ['TE']; te = float(os.environ['MEAN'])
pc = 3.0856775814913673e18; lsun = 3.828e33; h = 10.0 / 128
e = np.load(f'lex{name}-emission.npy'); o = np.load(f'lex{name}-emission.oiii.npy')
x = np.load(f'lex{name}-ionization.hii.npy')
# H-beta: the emission grid is H-alpha + H-beta, H-alpha / H-beta = the Balmer decrement.
dec = 2.86 * (te / 1e4) ** (np.log(2.86 / 3.04) / np.log(2)) if te < 1e4 else 2.86
hb = e.sum() * h**3 * 4 * np.pi * lsun / (1 + dec)
oiii = o.sum() * h**3 * 4 * np.pi * lsun / hb
# R_out: where the shell-averaged H+ fraction falls through 0.5 (about the grid's centre).
n = x.shape[0]; c = (np.arange(n) - (n - 1) / 2) * h
r = np.sqrt(c[:, None, None]**2 + c[None, :, None]**2 + c[None, None, :]**2)
edges = np.linspace(0, r.max(), 200); idx = np.digitize(r.ravel(), edges)
prof = np.array([x.ravel()[idx == i].mean() if (idx == i).any() else np.nan for i in range(1, len(edges))])
rc = 0.5 * (edges[1:] + edges[:-1]); ok = ~np.isnan(prof) & (rc > 1.2)
rout = np.interp(0.5, prof[ok][::-1], rc[ok][::-1]) * pc
codes_hb = np.mean([2.06, 2.02, 2.02, 2.10, 2.05, 2.07, 2.05, 2.02, 2.01]) * 1e37
codes_o3 = np.mean([2.21, 2.38, 2.20, 3.27, 1.93, 2.17, 2.08, 1.64, 2.34])
codes_r = np.mean([1.46, 1.46, 1.46, 1.45, 1.46, 1.47, 1.46, 1.46, 1.45]) * 1e19
label = f"thermal balance (mean {te:.0f} K)" if name == 'thermal' else f"{te:.0f} K"
print(f"lexington T_e {label}: L(H-beta) {hb:.4g} erg/s ({100*(hb/codes_hb-1):+.2f} % of the codes' mean "
      f"{codes_hb:.4g}); R_out {rout:.4g} cm ({100*(rout/codes_r-1):+.2f} % of {codes_r:.4g}); "
      f"[O III] 5007+4959 / H-beta {oiii:.3f} (codes' mean {codes_o3:.3f}: x{oiii/codes_o3:.2f})")
EOF
        echo "lexington T_e $te: nebionize $(cat lex.time)"
    done
    ;;
lineflux)
    $PY -c "import numpy as np; np.save('u.npy', np.full((48,48,48), 100, np.float32))"
    "$T/nebimport" -i u.npy --unit cm-3 --voxel-size 0.157697pc -o u.vdb
    "$T/nebionize" -i u.vdb --stars <(star s 0 0 0 1e49) --abundances he=0,n=0,o=0,s=0 \
        --electron-temperature 10000 --no-dust-absorption --kappa-v 1e-12 -o sf.vdb
    "$T/nebillum" -i sf.vdb -o sfl.vdb
    "$T/nebrender" -i sfl.vdb --spectral --camera orthographic --eye 0,0,-20 --distance 1000 \
        --pixel-size 30arcsec --res 64x64 --no-stars --fits-unit W/m2/sr/nm \
        -o sf.exr --png sf.png --fits sf.fits
    $PY - <<'EOF'
import numpy as np
from astropy.io import fits
h = fits.open('sf.fits'); t = h[0]
data = t.data  # (lambda, y, x)
hd = t.header
wave = hd['CRVAL3'] + (np.arange(data.shape[0]) + 1 - hd['CRPIX3']) * hd.get('CDELT3', hd.get('CD3_3'))
band = hd['BANDWID']
i = int(np.argmin(np.abs(wave * 1e9 - 656.28)))
pix = 30 / 206264.80624709636
flux = data[i].sum() * band * pix**2  # W m^-2
pc = 3.0856775814913673e16; D = 1000 * pc
hnu = 6.62607015e-34 * 299792458 / (656.28e-9 * 1.00028)
expected = 1e49 * (2.86 * 1.24e-25 / 2.59e-13) * 1e-7 / (4 * np.pi * (D * 100) ** 2) * 1e4 / 1e4
expected = 1e49 * 2.86 * 1.24e-25 / 2.59e-13 * 1e-7 / (4 * np.pi * D ** 2)  # W m^-2
print(f"lineflux: H-alpha band {wave[i]*1e9:.1f} nm: {flux:.5g} W/m^2; Q (alpha_eff/alpha_B) h nu / 4 pi D^2 "
      f"= {expected:.5g} ({100*(flux/expected-1):+.3f} %)")
EOF
    ;;
frontnoise)
    # A dense front seen face-on: n_H 30 cm^-3 in front of a tilted plane face of 3000, 64^3,
    # a 40 kK star 3 pc below. Each sight line's glow (the emission summed along z) against
    # the mean of its 9 x 9 neighbours: their rms spread is the front voxels' sampling noise
    # (plus the face's own voxel staircase), at three ray spacings.
    $PY -c "import numpy as np; x = np.arange(64)[:, None, None]; z = np.arange(64)[None, None, :]
np.save('tilt.npy', (np.where(z < 30 + 0.3 * (x - 32), 30.0, 3000.0) * np.ones((64, 64, 64))).astype(np.float32))"
    "$T/nebimport" -i tilt.npy --unit cm-3 --voxel-size 0.05pc -o tilt.vdb -q
    for sp in 0.5 0.25 0.125; do
        "$T/nebionize" -i tilt.vdb --star s:0,0,-3:1e5:40000 --no-dust-absorption \
            --electron-temperature 8000 --ray-spacing $sp -q -o t.vdb
        "$T/nebexport" -i t.vdb --grid emission -o t.npy 2>/dev/null
        SP=$sp $PY - <<'EOF2'
import numpy as np, os
m = np.load('t.npy').sum(axis=2)
c = np.pad(m, 4, mode='edge').cumsum(0).cumsum(1)
c = np.pad(c, ((1, 0), (1, 0)))
local = (c[9:, 9:] - c[:-9, 9:] - c[9:, :-9] + c[:-9, :-9]) / 81.0
r = (m / local)[8:-8, 8:-8]
print(f"frontnoise: ray spacing {os.environ['SP']}: sight lines' glow {100 * r.std():.1f} % rms "
      f"about their 9 x 9 mean")
EOF2
    done
    ;;
cost)
    # The preset's own three O stars (O5V, O7V, O9V: 2.5e49 photons a second) in the cavity
    # its warm gas fills.
    for res in ${RES:-128 512}; do
        "$T/nebgen" --preset pillars --res "$res" -o p.vdb
        $TIME -f "%e %M" -o t.txt "$T/nebionize" -i p.vdb -o cost.vdb
        read -r wall kb < t.txt
        echo "cost: pillars ${res}^3, 3 stars: ${wall} s, peak RSS $((kb / 1024)) MiB"
        rm -f p.vdb
    done
    ;;
*) echo "$SCRIPT: unknown part $part (stromgren photons lexington lineflux frontnoise cost)" >&2; exit 2 ;;
esac
done
