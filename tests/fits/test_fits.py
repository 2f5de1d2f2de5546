# SPDX-License-Identifier: Apache-2.0
"""nebrender --fits (DESIGN §13) against closed forms and astropy.

1. Absolute calibration: an optically thin uniform shell (n_H = 0.1 cm^-3 between 0.8 and
   2.2 pc, tau_V = 2e-4) around a 10^3 L_sun, 10^4 K star seen by the orthographic camera from
   1 kpc. Single scattering sends a k dR L_lambda / (4 pi) per steradian to the observer
   whatever the phase function (the star is at the centre), so the SCATTERED flux density is
   a k dR L_nu / (4 pi D^2) [Jy], with L_nu the star's black body (bolometric L) and k from
   CCM89 (written out here). Within 1 % at each wavelength; the DIRECT flux is
   L_nu e^-tau / (4 pi D^2) within 0.1 %; TOTAL = DIRECT + SCATTERED, FIELD = 0 (no field).
   The shell filled to the star (an embedded star): the same closed form within 0.3 %.
2. WCS: three stars' sprites (DIRECT centroids) map through astropy's WCS to the stars' sky
   positions, computed here from 3-D vectors (the gnomonic projection of the orthographic
   offsets / D, or of the perspective camera's directions), within 0.05 pixel, at several sky
   positions and position angles, one 0.05 degree from the celestial pole.
3. The header: BUNIT, EXTNAMEs, the WAVE axis' wavelengths, DISTANCE, the history; the
   W/m2/sr/nm unit consistent with MJy/sr.
3a. The layouts: the default (one 2-D image per component and wavelength, EXTVER, WAVELEN)
   opens HDU by HDU with a plain WCS(header) (and yt.load, if yt is installed); its world
   coordinates (sky position, WAVELEN) equal those of --fits-layout tab's WAVE-TAB cubes read
   with WCS(header, hdul), and its values and keywords are the cubes' bit for bit.
3b. Spectral mode (--spectral --fits): the shell's cube of 10 nm band means against the closed
   forms averaged over each band; the components adding up; the SED. Calibrated gas emission:
   a glowing sphere imported with nebimport --emission (BUNIT erg/s/cm3/sr) gives the line
   flux j V / D^2, each line in its band; RGB mode leaves the glow out. The calibrated
   spectral field against the RGB mode's field at the same wavelengths.
4. Refusals: exit 2, a message naming the option, nothing written.
"""
import json
import math
import os
import subprocess
import sys

import numpy as np
from astropy.io import fits
from astropy.wcs import WCS
import warnings

warnings.simplefilter("ignore")  # astropy's FITSFixedWarning notes on WCS defaults

tools, work = sys.argv[1], sys.argv[2]
os.makedirs(work, exist_ok=True)
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def run(*args, expect=0):
    r = subprocess.run([os.path.join(tools, args[0])] + list(args[1:]), capture_output=True,
                       text=True)
    if r.returncode != expect:
        print(r.stderr)
        raise SystemExit(f"{args[0]} exited {r.returncode}, expected {expect}")
    return r


def path(name):
    return os.path.join(work, name)


# Constants (CODATA 2018, IAU 2015), written out independently of the code.
h, c, k_B, sigma = 6.62607015e-34, 299792458.0, 1.380649e-23, 5.670374419e-8
L_SUN, PC = 3.828e26, 3.0856775814913673e16


def ccm89(lam_nm, rv=3.1):
    """A(lambda)/A_V, Cardelli, Clayton & Mathis 1989, optical (1.1 <= x <= 3.3 um^-1)."""
    x = 1000.0 / lam_nm
    y = x - 1.82
    a = (1 + 0.17699 * y - 0.50447 * y**2 - 0.02427 * y**3 + 0.72085 * y**4 + 0.01979 * y**5
         - 0.77530 * y**6 + 0.32999 * y**7)
    b = (1.41338 * y + 2.28305 * y**2 + 1.07233 * y**3 - 5.38434 * y**4 - 0.62251 * y**5
         + 5.30260 * y**6 - 2.09002 * y**7)
    return a + b / rv


def l_nu(L, T, lam_nm):
    """A black body's spectral luminosity [W/Hz] for bolometric L [L_sun]."""
    lam = lam_nm * 1e-9
    B = 2 * h * c**2 / lam**5 / np.expm1(h * c / (lam * k_B * T))
    L_lam = L * L_SUN * math.pi * B / (sigma * T**4)  # W/m
    return L_lam * lam**2 / c


# --- the shell: anti-aliased (4^3 samples per voxel) so its volume is right --------------
N, hv, R1, R2, n0 = 96, 0.05, 0.8, 2.2, 0.1
sub = (np.arange(4) + 0.5) / 4
coords = ((np.arange(N)[:, None] + sub[None, :]).ravel() - N / 2) * hv
x2 = coords**2
frac = np.zeros((N, N, N), dtype=np.float64)
for i in range(N * 4):
    r = np.sqrt(x2[i] + x2[:, None] + x2[None, :])
    inside = ((r >= R1) & (r <= R2)).astype(np.float64)
    frac[i // 4] += inside.reshape(N, 4, N, 4).sum(axis=(1, 3))
cube = (n0 * frac / 64).astype(np.float32)
np.save(path("shell.npy"), cube)
L, T, D = 1000.0, 10000.0, 1000.0
run("nebimport", "-i", path("shell.npy"), "--unit", "cm-3", "--voxel-size", "0.05pc",
    "--star", f"s:0,0,0:{L}:{T}", "-o", path("shell.vdb"))
run("nebillum", "-i", path("shell.vdb"), "-o", path("lit.vdb"))
W = 128
run("nebrender", "-i", path("lit.vdb"), "--camera", "orthographic", "--eye", "0,0,-10",
    "--look-at", "0,0,0", "--distance", str(D), "--pixel-size", "0.04pc", "--res", f"{W}x{W}",
    "--sky", "83.82,-5.39", "-o", path("shell.exr"), "--png", "none", "--fits",
    path("shell.fits"))
hdul = fits.open(path("shell.fits"))
COMPONENTS = ["TOTAL", "DIRECT", "SCATTERED", "SINGLE", "FIELD"]
ids = [(hdu.name, hdu.ver) for hdu in hdul]
check(ids == [(n, k) for n in COMPONENTS for k in (1, 2, 3)] + [("SED", 1)],
      f"HDUs (EXTNAME, EXTVER) {ids}")
head = hdul[0].header
dust = json.loads(head["DUST"])
waves = np.array([hdul["TOTAL", k + 1].header["WAVELEN"] for k in range(3)])
check(np.array_equal(waves, [435.8, 546.1, 700.0]) and
      all(hdul[n, k + 1].header["WAVELEN"] == waves[k] for n in COMPONENTS for k in range(3)),
      f"WAVELEN {waves} nm (ascending EXTVER)")
check(head["BUNIT"] == "MJy/sr" and head["DISTANCE"] == D, "BUNIT MJy/sr, DISTANCE")
history = "\n".join(str(x) for x in head["HISTORY"])
check(all(t in history for t in ("nebimport", "nebillum", "nebrender")), "history of the inputs")
# The pixel's solid angle from the WCS: |det CD| in deg^2.
wcs = WCS(head)  # the plain call: no HDUList
cd = wcs.wcs.cd
omega = abs(np.linalg.det(cd)) * (math.pi / 180) ** 2
check(abs(omega / (0.04 / D) ** 2 - 1) < 1e-9, f"pixel solid angle {omega:.6g} sr = (0.04 pc / D)^2")
for plane, lam in enumerate(waves):
    k = dust["kappa_V"] * ccm89(lam, dust.get("R_V", 3.1)) * n0  # per pc
    expected = dust["albedo"] * k * (R2 - R1) * l_nu(L, T, lam) / (4 * math.pi * (D * PC) ** 2)
    expected /= 1e-26  # Jy
    scattered = hdul["SCATTERED", plane + 1].data.astype(np.float64).sum() * omega * 1e6
    check(abs(scattered / expected - 1) < 0.01,
          f"{lam:.1f} nm: scattered {scattered:.6g} Jy, single-scattering closed form "
          f"{expected:.6g} Jy ({100 * (scattered / expected - 1):+.3f} %)")
    tau = k * (R2 - R1)
    direct_expected = l_nu(L, T, lam) * math.exp(-tau) / (4 * math.pi * (D * PC) ** 2) / 1e-26
    direct = hdul["DIRECT", plane + 1].data.astype(np.float64).sum() * omega * 1e6
    check(abs(direct / direct_expected - 1) < 1e-3,
          f"{lam:.1f} nm: direct {direct:.6g} Jy, L_nu e^-tau / (4 pi D^2) {direct_expected:.6g}")
    total = hdul["TOTAL", plane + 1].data.astype(np.float64)
    parts = hdul["DIRECT", plane + 1].data + hdul["SCATTERED", plane + 1].data
    check(np.allclose(total, parts, rtol=1e-5, atol=1e-6 * total.max()), f"{lam:.1f} nm: TOTAL = DIRECT + SCATTERED")
    check(not hdul["FIELD", plane + 1].data.any(), f"{lam:.1f} nm: FIELD = 0 without a field")
# The same render in W/m2/sr/nm: I_nu = I_lambda lambda^2 / c.
run("nebrender", "-i", path("lit.vdb"), "--camera", "orthographic", "--eye", "0,0,-10",
    "--distance", str(D), "--pixel-size", "0.04pc", "--res", f"{W}x{W}", "-o",
    path("si.exr"), "--png", "none", "--fits", path("si.fits"), "--fits-unit", "W/m2/sr/nm")
si = fits.open(path("si.fits"))
check(si[0].header["BUNIT"] == "W/m2/sr/nm" and si[0].header["CTYPE1"] == "XOFFSET",
      "W/m2/sr/nm, linear WCS in pc without --sky")
for plane, lam in enumerate(waves):
    a = hdul["TOTAL", plane + 1].data.astype(np.float64)
    b = si["TOTAL", plane + 1].data.astype(np.float64) * 1e9 * (lam * 1e-9) ** 2 / c / 1e-20
    check(np.allclose(a, b, rtol=1e-5, atol=1e-6 * a.max()), f"{lam:.1f} nm: MJy/sr = W/m2/sr/nm x lambda^2/c")

# --- the embedded star: the shell filled to the star (DESIGN §3.5) ------------------------
# The same star with the dust right up to it (R1 = 0), where its light grows as 1/r^2 within
# the voxels round it and as 1/b in the pixels round its image (at their common corner): the
# same closed form a k R2 L_nu / (4 pi D^2), within 0.3 % at each wavelength (0.987 before
# single scattering integrated the 1/r^2 exactly).
full = np.zeros((N, N, N), dtype=np.float64)
for i in range(N * 4):
    r = np.sqrt(x2[i] + x2[:, None] + x2[None, :])
    full[i // 4] += (r <= R2).astype(np.float64).reshape(N, 4, N, 4).sum(axis=(1, 3))
np.save(path("sphere.npy"), (n0 * full / 64).astype(np.float32))
run("nebimport", "-i", path("sphere.npy"), "--unit", "cm-3", "--voxel-size", "0.05pc",
    "--star", f"s:0,0,0:{L}:{T}", "-o", path("sphere.vdb"))
run("nebillum", "-i", path("sphere.vdb"), "-o", path("sphere-lit.vdb"))
run("nebrender", "-i", path("sphere-lit.vdb"), "--camera", "orthographic", "--eye", "0,0,-10",
    "--look-at", "0,0,0", "--distance", str(D), "--pixel-size", "0.04pc", "--res", f"{W}x{W}",
    "--sky", "83.82,-5.39", "-o", path("sphere.exr"), "--png", "none", "--fits",
    path("sphere.fits"))
embedded = fits.open(path("sphere.fits"))
for plane, lam in enumerate(waves):
    k = dust["kappa_V"] * ccm89(lam, dust.get("R_V", 3.1)) * n0
    expected = dust["albedo"] * k * R2 * l_nu(L, T, lam) / (4 * math.pi * (D * PC) ** 2) / 1e-26
    scattered = embedded["SCATTERED", plane + 1].data.astype(np.float64).sum() * omega * 1e6
    check(abs(scattered / expected - 1) < 3e-3,
          f"{lam:.1f} nm: embedded star, scattered {scattered:.6g} Jy, closed form "
          f"{expected:.6g} Jy ({100 * (scattered / expected - 1):+.3f} %)")

# --- the layouts: planes (default) against --fits-layout tab --------------------------------
# The same renders with --fits-layout tab: one cube per component on a WAVE-TAB axis, which
# only WCS(header, hdul) reads. Every image HDU of the default opens with the plain
# WCS(header); a pixel's world coordinates (sky or pc offsets, and WAVELEN) are the -TAB
# cube's, and the values and the other keywords are the cubes' bit for bit.
TAB_ONLY = {"NAXIS", "NAXIS3", "CTYPE3", "CUNIT3", "CRPIX3", "CRVAL3", "CD3_3", "CDELT3",
            "PS3_0", "PS3_1",
            "HISTORY",  # the command differs (--fits-layout tab)
            # a primary HDU's or an extension's, and cfitsio's comments on the primary
            "SIMPLE", "EXTEND", "XTENSION", "PCOUNT", "GCOUNT", "COMMENT"}


def compare_layouts(planes_file, tab_file, label):
    pl, tb = fits.open(planes_file), fits.open(tab_file)
    tnames = [hdu.name for hdu in tb]
    check(tnames == COMPONENTS + ["WCS-TAB", "SED"], f"{label}: tab layout HDUs {tnames}")
    images = [hdu for hdu in pl if hdu.is_image]
    check(len(images) == 15 and len(pl) == 16, f"{label}: 15 image HDUs and the SED")
    bad_wcs, bad_world, bad_data, bad_keys = [], [], [], []
    pixels = [(0.0, 0.0), (17.25, 90.5), (W - 1.0, W / 2 - 0.5)]
    for hdu in images:
        k = hdu.ver - 1
        cube = tb[hdu.name]
        wt = WCS(cube.header, fobj=tb)
        try:
            w = WCS(hdu.header)  # no HDUList
        except Exception as e:  # what the -TAB cube raises without its HDUList
            bad_wcs.append(f"{hdu.name},{hdu.ver}: {e}")
            continue
        if w.naxis != 2:
            bad_wcs.append(f"{hdu.name},{hdu.ver}: {w.naxis} WCS axes")
            continue
        for px, py in pixels:
            x, y = w.pixel_to_world_values(px, py)
            xt, yt, lam = wt.pixel_to_world_values(px, py, k)
            if not (x == xt and y == yt and hdu.header["WAVELEN"] * 1e-9 == lam):
                bad_world.append(f"{hdu.name},{hdu.ver} ({px}, {py}): {x!r}, {y!r}, "
                                 f"{hdu.header['WAVELEN']} nm against {xt!r}, {yt!r}, {lam!r} m")
        if not (hdu.data.dtype == cube.data.dtype and np.array_equal(hdu.data, cube.data[k])):
            bad_data.append(f"{hdu.name},{hdu.ver}")
        want = {key: cube.header[key] for key in cube.header if key not in TAB_ONLY and key}
        got = {key: hdu.header[key] for key in hdu.header
               if key not in TAB_ONLY and key not in ("EXTVER", "WAVELEN") and key}
        if {k: str(v) for k, v in want.items()} != {k: str(v) for k, v in got.items()}:
            bad_keys.append(f"{hdu.name},{hdu.ver}: " + ", ".join(
                sorted(set(want) ^ set(got)) or
                [key for key in want if str(want[key]) != str(got[key])]))
    check(not bad_wcs, f"{label}: every image HDU opens with a plain WCS(header), 2 axes {bad_wcs[:2]}")
    check(not bad_world, f"{label}: world coordinates of 3 pixels (and WAVELEN) = the WAVE-TAB cube's {bad_world[:2]}")
    check(not bad_data, f"{label}: every plane = the tab layout's bit for bit {bad_data[:3]}")
    check(not bad_keys, f"{label}: the same keywords and values as the cubes {bad_keys[:2]}")
    check(np.array_equal(pl["SED"].data, tb["SED"].data), f"{label}: the same SED table")
    how = [str(x) for x in pl[0].header["COMMENT"] if "WAVELEN" in str(x)]
    check(how and how == [str(x) for x in tb[0].header["COMMENT"] if "WAVELEN" in str(x)],
          f"{label}: the same COMMENT on the method")
    try:  # the -TAB cube itself needs its HDUList: what the default layout avoids
        WCS(tb[0].header)
        check(False, f"{label}: WCS(header) of a WAVE-TAB cube without its HDUList")
    except Exception:
        pass


run("nebrender", "-i", path("lit.vdb"), "--camera", "orthographic", "--eye", "0,0,-10",
    "--look-at", "0,0,0", "--distance", str(D), "--pixel-size", "0.04pc", "--res", f"{W}x{W}",
    "--sky", "83.82,-5.39", "-o", path("shell-tab.exr"), "--png", "none", "--fits",
    path("shell-tab.fits"), "--fits-layout", "tab")
compare_layouts(path("shell.fits"), path("shell-tab.fits"), "--sky")
run("nebrender", "-i", path("lit.vdb"), "--camera", "orthographic", "--eye", "0,0,-10",
    "--distance", str(D), "--pixel-size", "0.04pc", "--res", f"{W}x{W}", "-o",
    path("si-tab.exr"), "--png", "none", "--fits", path("si-tab.fits"), "--fits-unit",
    "W/m2/sr/nm", "--fits-layout", "tab")
compare_layouts(path("si.fits"), path("si-tab.fits"), "offsets in pc, W/m2/sr/nm")

# --- spectral mode: an (x, y, lambda) cube of band means --------------------------------
# The same shell rendered spectrally: 47 bands of 10 nm over 360-830 nm (the default with
# --fits), each plane the band's mean; the closed forms above averaged over each band
# (integrated here on 201 points per band) within 1 % (scattered) and 0.5 % (direct).
run("nebrender", "-i", path("lit.vdb"), "--spectral", "--camera", "orthographic", "--eye",
    "0,0,-10", "--look-at", "0,0,0", "--distance", str(D), "--pixel-size", "0.04pc", "--res",
    f"{W}x{W}", "--sky", "83.82,-5.39", "-o", path("spec.exr"), "--png", "none", "--fits",
    path("spec.fits"), "--sed", path("spec.csv"))
sp = fits.open(path("spec.fits"))
names = [hdu.name for hdu in sp]
check(names == ["TOTAL", "DIRECT", "SCATTERED", "SINGLE", "FIELD", "EMISSION", "SED"],
      f"spectral HDUs {names}")
sw = WCS(sp[0].header)
centres = sw.pixel_to_world_values(0, 0, np.arange(47))[2] * 1e9
check(sp[0].data.shape == (47, W, W) and np.allclose(centres, 365 + 10 * np.arange(47)),
      f"spectral WAVE axis: 47 band centres 365 ... 825 nm ({centres[0]:.3f} ... {centres[-1]:.3f})")
check(sp[0].header["BANDWID"] == 10.0 and sp[0].header["CTYPE3"] == "WAVE", "linear WAVE axis, BANDWID 10 nm")
worst_sc, worst_di = 0.0, 0.0
for plane, centre in enumerate(centres):
    band = np.linspace(centre - 5, centre + 5, 201)
    k_band = dust["kappa_V"] * ccm89(band, dust.get("R_V", 3.1)) * n0
    l_lam = l_nu(L, T, band) * c / (band * 1e-9) ** 2  # W/m
    to_jy = (centre * 1e-9) ** 2 / c / (4 * math.pi * (D * PC) ** 2) / 1e-26
    expected = np.trapz(dust["albedo"] * k_band * (R2 - R1) * l_lam, band) / 10 * to_jy
    direct_expected = np.trapz(l_lam * np.exp(-k_band * (R2 - R1)), band) / 10 * to_jy
    scattered = sp["SCATTERED"].data[plane].astype(np.float64).sum() * omega * 1e6
    direct = sp["DIRECT"].data[plane].astype(np.float64).sum() * omega * 1e6
    worst_sc = max(worst_sc, abs(scattered / expected - 1))
    worst_di = max(worst_di, abs(direct / direct_expected - 1))
check(worst_sc < 0.01, f"spectral: scattered flux in each of 47 bands against the band-averaged closed form, worst {100 * worst_sc:.3f} %")
check(worst_di < 0.005, f"spectral: direct flux in each band against L_nu e^-tau / (4 pi D^2), worst {100 * worst_di:.3f} %")
tot = sp["TOTAL"].data.astype(np.float64)
parts = sum(sp[n].data.astype(np.float64) for n in ("DIRECT", "SCATTERED", "EMISSION"))
check(np.allclose(tot, parts, rtol=1e-5, atol=1e-6 * tot.max()), "spectral: TOTAL = DIRECT + SCATTERED + EMISSION")
check(not sp["EMISSION"].data.any() and not sp["FIELD"].data.any(), "spectral: EMISSION = FIELD = 0 (no gas glow, no field)")
rows = [line for line in open(path("spec.csv")) if not line.startswith("#")]
check(rows[0].strip().endswith(",emission_Jy") and len(rows) == 48, "spectral SED: 47 rows with emission_Jy")
sed_total = np.array([float(r.split(",")[1]) for r in rows[1:]])
cube_total = tot.sum(axis=(1, 2)) * omega * 1e6
check(np.allclose(sed_total, cube_total, rtol=1e-5), "spectral SED total = the cube's flux per plane")
plain = [WCS(hdu.header) for hdu in sp if hdu.is_image]  # no HDUList
check(len(plain) == 6 and all(np.array_equal(w.pixel_to_world_values(5, 7, np.arange(47))[2] * 1e9, centres)
                              for w in plain),
      "spectral: every cube opens with a plain WCS(header), the same band centres")

# yt (if installed; Debian: python3-yt) opens both: each image HDU a field named after BTYPE
# and numbered in HDU order, the values the HDUs'.
try:
    import yt
except ImportError:
    print("note: yt is not installed (Debian: python3-yt): the yt.load checks are skipped")
else:
    yt.set_log_level(50)
    for name, want in (("shell.fits", [W, W, 1]), ("spec.fits", [W, W, 47])):
        ds = yt.load(path(name), nprocs=1)  # one grid (yt 4.1's split cube fails to read)
        grid = ds.covering_grid(0, ds.domain_left_edge, ds.domain_dimensions)
        hdus = [hdu for hdu in fits.open(path(name)) if hdu.is_image]
        same = []
        for i, hdu in enumerate(hdus):
            v = np.asarray(grid["fits", "phot.flux.density.sb" + (f"_{i}" if i else "")])
            same.append(np.array_equal(v.T if v.shape[2] > 1 else v[:, :, 0].T, hdu.data.astype(v.dtype)))
        check(list(ds.domain_dimensions) == want and len(ds.field_list) == len(hdus) and all(same),
              f"yt.load {name}: {ds.domain_dimensions}, {len(ds.field_list)} fields = the {len(hdus)} image HDUs")

# --- the spectral field, calibrated: against the RGB mode's at the same wavelengths ------
# nebscatter --spectral's field is made with luminance-normalised stars and scaled per star to
# the bolometric black body; nebscatter's R, G, B field with sRGB colours and scaled per
# channel. Two independent Monte Carlo fields (50 000 packets; two seeds of the RGB one agree
# within 0.9 %) at the bands' centres 435, 545, 695 nm: the FIELD fluxes within 3 % (the
# spectral field is linear in wavelength between its six wavelengths: about +1 %).
run("nebscatter", "-i", path("lit.vdb"), "--packets", "50000", "--wavelengths", "695,545,435",
    "-o", path("field-rgb.vdb"))
run("nebscatter", "-i", path("lit.vdb"), "--packets", "50000", "--spectral", "6", "-o",
    path("field-spec.vdb"))
cam = ["--camera", "orthographic", "--eye", "0,0,-10", "--distance", str(D), "--pixel-size",
       "0.04pc", "--res", f"{W}x{W}", "--png", "none"]
run("nebrender", "-i", path("field-rgb.vdb"), "--wavelengths", "695,545,435", *cam, "-o",
    path("frgb.exr"), "--sed", path("frgb.csv"))
run("nebrender", "-i", path("field-spec.vdb"), "--spectral", *cam, "-o", path("fspec.exr"),
    "--sed", path("fspec.csv"))


def sed_rows(name):
    lines = [line for line in open(path(name)) if not line.startswith("#")]
    return {round(float(r.split(",")[0])): float(r.split(",")[5]) for r in lines[1:]}


frgb, fspec = sed_rows("frgb.csv"), sed_rows("fspec.csv")
for lam in (435, 545, 695):
    check(frgb[lam] > 0 and abs(fspec[lam] / frgb[lam] - 1) < 0.03,
          f"field at {lam} nm: spectral {fspec[lam]:.5g} Jy, RGB {frgb[lam]:.5g} Jy "
          f"({100 * (fspec[lam] / frgb[lam] - 1):+.2f} %)")

# One spectral field of two stars of different temperatures cannot be scaled to both.
run("nebillum", "-i", path("shell.vdb"), "--star", "hot:0.5,0,0:100:20000", "--star",
    "cool:-0.5,0,0:100:4000", "-o", path("two.vdb"))
run("nebscatter", "-i", path("two.vdb"), "--packets", "2000", "--spectral", "2", "-o",
    path("two-field.vdb"))
r = run("nebrender", "-i", path("two-field.vdb"), "--spectral", *cam, "-o", path("bad.exr"),
        "--fits", path("bad.fits"), expect=1)
check("--per-star" in r.stderr and not [n for n in os.listdir(work) if n.startswith("bad")],
      f"a spectral field of stars of two temperatures is refused for --fits: {r.stderr.strip()[:110]}")

# --- calibrated gas emission: a glowing sphere imported with nebimport --emission --------
# A uniform sphere (R 1 pc, anti-aliased) of emissivity j = 1e-21 erg/s/cm3/sr (BUNIT in a
# FITS written by astropy) in H-alpha and H-beta (1 : 0.35), nearly no dust: the line flux at
# the observer is j V / D^2, all of it in the EMISSION cube, H-alpha's share in the band of
# 650-660 nm and H-beta's in 480-490 nm. Within 1 %.
Ne, he, Re = 48, 0.05, 1.0
sub = (np.arange(4) + 0.5) / 4
ce = ((np.arange(Ne)[:, None] + sub[None, :]).ravel() - Ne / 2) * he
sphere = np.zeros((Ne, Ne, Ne))
for i in range(Ne * 4):
    r = np.sqrt(ce[i] ** 2 + ce[:, None] ** 2 + ce[None, :] ** 2)
    sphere[i // 4] += (r <= Re).astype(np.float64).reshape(Ne, 4, Ne, 4).sum(axis=(1, 3))
sphere /= 64
j_cgs = 1e-21
hdu = fits.PrimaryHDU((j_cgs * sphere).T.astype(np.float32))  # FITS axes (x, y, z)
hdu.header["BUNIT"] = "erg/s/cm3/sr"
hdu.writeto(path("em.fits"), overwrite=True)
np.save(path("emdens.npy"), (1e-6 * (sphere > 0)).astype(np.float32))
run("nebimport", "-i", path("emdens.npy"), "--unit", "cm-3", "--voxel-size", "0.05pc",
    "--emission", path("em.fits"), "--lines", "H-alpha:1,H-beta:0.35", "--star",
    "s:0,0,-8:1:5000", "-o", path("em.vdb"))
run("nebillum", "-i", path("em.vdb"), "-o", path("emlit.vdb"))
De = 500.0
run("nebrender", "-i", path("emlit.vdb"), "--spectral", "--camera", "orthographic", "--eye",
    "0,0,-10", "--look-at", "0,0,0", "--distance", str(De), "--pixel-size", "0.04pc", "--res",
    "64x64", "-o", path("em.exr"), "--png", "none", "--no-stars", "--fits", path("emc.fits"),
    "--fits-unit", "W/m2/sr/nm")
em = fits.open(path("emc.fits"))
omega_e = (0.04 / De) ** 2
per_plane = em["EMISSION"].data.astype(np.float64).sum(axis=(1, 2)) * omega_e * 10.0  # W/m2
V = sphere.sum() * (he * PC) ** 3
want = j_cgs * 1e-7 * 1e6 * V / (De * PC) ** 2  # W/m2
got = per_plane.sum()
check(abs(got / want - 1) < 0.01, f"emission: line flux {got:.6g} W/m2, j V / D^2 {want:.6g} ({100 * (got / want - 1):+.3f} %)")
check(abs(per_plane[29] / got - 1 / 1.35) < 1e-3 and abs(per_plane[12] / got - 0.35 / 1.35) < 1e-3,
      f"emission: H-alpha in 650-660 nm ({per_plane[29] / got:.5f}), H-beta in 480-490 nm ({per_plane[12] / got:.5f}) of the flux")
check(em[0].header["EMSCALE"] == 1.0, "EMSCALE in the header")
# The same grid in RGB mode: no calibrated emission, so no EMISSION HDU and a warning.
r = run("nebrender", "-i", path("emlit.vdb"), "--camera", "orthographic", "--eye", "0,0,-10",
        "--distance", str(De), "--pixel-size", "0.04pc", "--res", "32x32", "-o", path("emrgb.exr"),
        "--png", "none", "--fits", path("emrgb.fits"))
check("EMISSION" not in [h.name for h in fits.open(path("emrgb.fits"))] and "--spectral" in r.stderr,
      "RGB mode: the glow is left out, with a warning pointing at --spectral")
# A unit that disagrees with the file's, and --lines without --emission.
r = run("nebimport", "-i", path("emdens.npy"), "--unit", "cm-3", "--voxel-size", "0.05pc",
        "--emission", path("em.fits"), "--emission-unit", "Lsun/pc3/sr", "-o", path("bad.vdb"), expect=1)
check("erg/s/cm3/sr" in r.stderr and not os.path.exists(path("bad.vdb")),
      f"an emission unit that disagrees with BUNIT is refused: {r.stderr.strip()[:100]}")
r = run("nebimport", "-i", path("emdens.npy"), "--unit", "cm-3", "--voxel-size", "0.05pc",
        "--lines", "H-alpha", "-o", path("bad.vdb"), expect=2)
check("--emission" in r.stderr, "--lines without --emission is refused")

# --- WCS: three stars' sprites against their sky positions --------------------------------
stars = [("a", (0.9, 0.4, -0.3)), ("b", (-1.3, -0.7, 0.5)), ("c", (0.2, 1.6, 1.1))]
args = []
for name, p in stars:
    args += ["--star", f"{name}:{p[0]},{p[1]},{p[2]}:100:6000"]
run("nebillum", "-i", path("shell.vdb"), *args, "-o", path("stars.vdb"))


def basis(eye, look, up):
    f = np.subtract(look, eye) / np.linalg.norm(np.subtract(look, eye))
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    return f, r, np.cross(r, f)


def sky_of(xi, eta, ra0, dec0, pa):
    """The sky position of tangent-plane offsets (xi along the image's right, eta up) [rad]
    for an image whose up is at position angle pa (north through east) and whose centre is
    (ra0, dec0): the gnomonic projection's inverse, in 3-D vectors."""
    a, d, t = np.radians([ra0, dec0, pa])
    centre = np.array([math.cos(d) * math.cos(a), math.cos(d) * math.sin(a), math.sin(d)])
    east = np.array([-math.sin(a), math.cos(a), 0.0])
    north = np.cross(centre, east)
    e = -math.cos(t) * xi + math.sin(t) * eta
    n = math.sin(t) * xi + math.cos(t) * eta
    v = centre + e * east + n * north
    v /= np.linalg.norm(v)
    return math.degrees(math.atan2(v[1], v[0])) % 360, math.degrees(math.asin(v[2]))


def separation(ra1, dec1, ra2, dec2):
    v = [np.array([math.cos(math.radians(d)) * math.cos(math.radians(r)),
                   math.cos(math.radians(d)) * math.sin(math.radians(r)), math.sin(math.radians(d))])
         for r, d in ((ra1, dec1), (ra2, dec2))]
    return math.degrees(math.atan2(np.linalg.norm(np.cross(v[0], v[1])), np.dot(v[0], v[1])))


cases = [("orthographic", 10.0, 20.0, 0.0), ("orthographic", 250.0, -45.0, 35.0),
         ("orthographic", 123.0, 89.95, 120.0), ("orthographic", 359.99, -89.9, -70.0),
         ("perspective", 45.0, 10.0, 15.0)]
eye, look, up = (1.0, 0.5, -12.0), (0.1, -0.2, 0.3), (0.2, 1.0, 0.1)
f, right, upv = basis(eye, look, up)
for model, ra0, dec0, pa in cases:
    out = path("wcs.fits")
    cam = ["--camera", model, "--eye", ",".join(map(str, eye)), "--look-at",
           ",".join(map(str, look)), "--up", ",".join(map(str, up)), "--res", "160x120"]
    cam += ["--distance", "700", "--pixel-size", "0.035pc"] if model == "orthographic" else ["--fov", "25"]
    run("nebrender", "-i", path("stars.vdb"), *cam, "--sky", f"{ra0},{dec0}", "--position-angle",
        str(pa), "-o", path("wcs.exr"), "--png", "none", "--fits", out)
    hd = fits.open(out)
    w = WCS(hd["DIRECT", 2].header)  # the plain call, on the 546.1 nm plane
    scale = math.sqrt(abs(np.linalg.det(w.wcs.cd)))  # deg per pixel
    direct = hd["DIRECT", 2].data.astype(np.float64)
    for name, p in stars:
        v = np.subtract(p, look) if model == "orthographic" else np.subtract(p, eye)
        if model == "orthographic":
            xi, eta = np.dot(v, right) / 700.0, np.dot(v, upv) / 700.0
            px = 80 + np.dot(v, right) / 0.035 - 0.5  # 0-based FITS pixel (numpy column)
            py = 60 + np.dot(v, upv) / 0.035 - 0.5
        else:
            z = np.dot(v, f)
            xi, eta = np.dot(v, right) / z, np.dot(v, upv) / z
            tanh = math.tan(math.radians(12.5))
            px = 80 + xi / (2 * tanh / 160) - 0.5  # square pixels of 2 tan(fov/2) / W
            py = 60 + eta / (2 * tanh / 160) - 0.5
        x0, y0 = int(round(px)), int(round(py))
        win = direct[y0 - 6:y0 + 7, x0 - 6:x0 + 7]
        yy, xx = np.mgrid[y0 - 6:y0 + 7, x0 - 6:x0 + 7]
        cx, cy = (win * xx).sum() / win.sum(), (win * yy).sum() / win.sum()
        ra, dec = w.pixel_to_world_values(cx, cy)
        want = sky_of(xi, eta, ra0, dec0, pa)
        off = separation(float(ra), float(dec), *want) / scale
        check(off < 0.05, f"{model} sky {ra0},{dec0} PA {pa}: star {name} at pixel "
              f"({cx:.3f}, {cy:.3f}) -> {float(ra):.6f}, {float(dec):.6f}; expected "
              f"{want[0]:.6f}, {want[1]:.6f}: {off:.4f} pixel")

# --- filter photometry: a black-body star through every shipped filter -------------------
# The render's band average (--filter X --sed: its DIRECT flux, the sprite of a star behind a
# nearly empty shell) against direct integration of the filter's data file here: <f_nu> =
# int f_nu T dl/l / int T dl/l, T photon-counting (an energy response divided by lambda),
# linear between the file's points; AB magnitudes within 0.01 mag (the target).
data = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "libnebula", "data",
                    "filters")


def read_filter(fname):
    unit, energy, lam, resp = 1.0, False, [], []
    with open(os.path.join(data, fname)) as f:
        for line in f:
            line = line.split("#")[0].strip()
            if not line:
                continue
            parts = [p for p in line.replace(",", " ").replace(":", " ").split() if p]
            if parts[0] == "unit":
                unit = {"nm": 1.0, "Angstrom": 0.1, "A": 0.1, "um": 1000.0, "micron": 1000.0}[parts[1]]
            elif parts[0] == "response":
                energy = parts[1] == "energy"
            else:
                lam.append(float(parts[0]) * unit)
                resp.append(float(parts[1]))
    lam, resp = np.array(lam), np.array(resp)
    return lam, resp / lam if energy else resp


def band_average(lam, T, fnu):
    x = np.linspace(lam[0], lam[-1], 200001)
    w = np.interp(x, lam, T) / x
    return np.trapz(fnu(x) * w, x) / np.trapz(w, x)


files = {"U": "bessell_U.csv", "B": "bessell_B.csv", "V": "bessell_V.csv", "R": "bessell_R.csv",
         "I": "bessell_I.csv", "sdss_u": "sdss_u.csv", "sdss_g": "sdss_g.csv",
         "sdss_r": "sdss_r.csv", "sdss_i": "sdss_i.csv", "sdss_z": "sdss_z.csv",
         "F435W": "acs_wfc_F435W.csv", "F555W": "acs_wfc_F555W.csv", "F814W": "acs_wfc_F814W.csv"}
Tstar, Lstar = 4500.0, 50.0
run("nebillum", "-i", path("shell.vdb"), "--star", f"p:0,0,-3:{Lstar}:{Tstar}", "-o",
    path("phot.vdb"))
worst = 0.0
for name, fname in files.items():
    run("nebrender", "-i", path("phot.vdb"), "--camera", "orthographic", "--eye", "0,0,-10",
        "--distance", "1000", "--pixel-size", "0.1pc", "--res", "64x64", "-o", path("phot.exr"),
        "--png", "none", "--sed", path("phot.csv"), "--filter", name)
    rows = [line for line in open(path("phot.csv")) if not line.startswith("#")]
    direct = float(rows[1].split(",")[2])
    lam, T = read_filter(fname)
    # The star at z = -3 pc lies outside the shell (R2 = 2.2 pc), between it and the eye's
    # plane: its light reaches the observer unattenuated.
    want = band_average(lam, T, lambda x: l_nu(Lstar, Tstar, x)) / (4 * math.pi * (1000 * PC) ** 2) / 1e-26
    dm = -2.5 * math.log10(direct / want)
    worst = max(worst, abs(dm))
    check(abs(dm) < 0.01, f"filter {name}: AB {-2.5 * math.log10(direct / 3631):.4f}, direct "
          f"integration {-2.5 * math.log10(want / 3631):.4f} ({dm:+.5f} mag)")
print(f"worst filter photometry difference: {worst:.5f} mag")
# Spectral mode: the band average from the spectral layers (the spectrum constant across each
# 10 nm band, the filter curve integrated exactly), for every filter inside 360-830 nm (all
# but 1e-3 of its weight); the others are refused (exit 2): part of their band is not rendered.
worst_sp = 0.0
for name, fname in files.items():
    lam, T = read_filter(fname)
    # Refused when more than 1e-3 of the band's weight lies outside 360-830 nm.
    inside = band_average(lam, T, lambda x: ((x >= 360) & (x <= 830)).astype(float)) >= 1 - 1e-3
    r = run("nebrender", "-i", path("phot.vdb"), "--spectral", "--camera", "orthographic", "--eye",
            "0,0,-10", "--distance", "1000", "--pixel-size", "0.1pc", "--res", "32x32", "-o",
            path("phot.exr"), "--png", "none", "--sed", path("phot.csv"), "--filter", name,
            expect=0 if inside else 2)
    if not inside:
        check("360-830" in r.stderr, f"spectral --filter {name} (beyond 360-830 nm) refused: {r.stderr.strip()[:120]}")
        continue
    rows = [line for line in open(path("phot.csv")) if not line.startswith("#")]
    direct = float(rows[1].split(",")[2])
    want = band_average(lam, T, lambda x: l_nu(Lstar, Tstar, x)) / (4 * math.pi * (1000 * PC) ** 2) / 1e-26
    dm = -2.5 * math.log10(direct / want)
    worst_sp = max(worst_sp, abs(dm))
    check(abs(dm) < 0.01, f"spectral --filter {name}: {dm:+.5f} mag against direct integration")
print(f"worst spectral filter photometry difference: {worst_sp:.5f} mag")
# A filter file of one's own, and one that is not monotonic.
with open(path("box.dat"), "w") as f:
    f.write("# a box from 500 to 600 nm\n499 0\n500 1\n600 1\n601 0\n")
run("nebrender", "-i", path("phot.vdb"), "--camera", "orthographic", "--eye", "0,0,-10",
    "--distance", "1000", "--pixel-size", "0.1pc", "--res", "64x64", "-o", path("phot.exr"),
    "--png", "none", "--sed", path("phot.csv"), "--filter-file", path("box.dat"))
rows = [line for line in open(path("phot.csv")) if not line.startswith("#")]
box = band_average(np.array([499.0, 500, 600, 601]), np.array([0.0, 1, 1, 0]),
                   lambda x: l_nu(Lstar, Tstar, x)) / (4 * math.pi * (1000 * PC) ** 2) / 1e-26
check(abs(float(rows[1].split(",")[2]) / box - 1) < 0.005, "--filter-file: a box filter's band average")
with open(path("zigzag.dat"), "w") as f:
    f.write("500 0.5\n600 1\n550 0.3\n")
r = run("nebrender", "-i", path("phot.vdb"), "--camera", "orthographic", "--eye", "0,0,-10",
        "-o", path("bad.exr"), "--png", "none", "--sed", path("bad.csv"), "--filter-file",
        path("zigzag.dat"), expect=1)
check("monotonic" in r.stderr and not [n for n in os.listdir(work) if n.startswith("bad")],
      f"a filter file not monotonic in wavelength is refused: {r.stderr.strip()[:100]}")

# A filter file that names its unit twice: the second line would silently win.
with open(path("twice.dat"), "w") as f:
    f.write("unit, nm\n# and again\nunit, um\n0.5 0\n0.6 1\n0.7 0\n")
r = run("nebrender", "-i", path("phot.vdb"), "--camera", "orthographic", "--eye", "0,0,-10",
        "-o", path("bad.exr"), "--png", "none", "--sed", path("bad.csv"), "--filter-file",
        path("twice.dat"), expect=1)
check("twice.dat" in r.stderr and ":3:" in r.stderr and "line 1" in r.stderr
      and not [n for n in os.listdir(work) if n.startswith("bad")],
      f"a filter file with two unit lines is refused, naming the file and lines: {r.stderr.strip()[:120]}")

# --- refusals: exit 2, the option named, nothing written -----------------------------------
# A filter file beyond the extinction curve (CCM89: 125-3333 nm): the file is to blame, not
# --wavelengths, which the user never gave.
with open(path("ir.dat"), "w") as f:
    f.write("unit um\n3.4 0\n3.5 1\n3.7 1\n3.8 0\n")
base = ["-i", path("lit.vdb"), "-o", path("bad.exr"), "--png", "none", "--fits", path("bad.fits")]
for extra, needles, code in [
        (["--camera", "orthographic", "--distance", "0"], ["--distance"], 2),
        (["--camera", "fisheye", "--res", "64x64"], ["--fits"], 2),
        (["--camera", "perspective"], ["--sky"], 2),
        (["--camera", "orthographic", "--sky", "400,0"], ["--sky"], 2),
        (["--camera", "orthographic", "--pixel-size", "2arcsec"], ["--distance"], 2),
        (["--camera", "orthographic", "--fits-unit", "Jy"], ["--fits-unit"], 2),
        (["--camera", "orthographic", "--fits-layout", "cube"], ["--fits-layout"], 2),
        (["--camera", "orthographic", "--fits-layout", "tab", "--spectral"], ["--fits-layout", "--spectral"], 2),
        (["--camera", "orthographic", "--fits-layout", "tab", "--filter", "V"], ["--fits-layout", "--filter"], 2),
        (["--camera", "orthographic", "--wavelengths", "0,546.1,435.8"], ["--wavelengths", "0 nm"], 2),
        (["--camera", "orthographic", "--wavelengths", "700,-1,435.8"], ["--wavelengths", "-1 nm"], 2),
        (["--camera", "orthographic", "--wavelengths", "700,546.1,50"], ["--wavelengths", "50 nm", "125-3333"], 2),
        (["--camera", "orthographic", "--filter-file", path("ir.dat")], ["--filter-file", "ir.dat", "125-3333"], 2),
        (["--camera", "orthographic", "--distance", "1e-300"], ["--distance"], 2),
        (["--camera", "orthographic", "--distance", "1e-300", "--pixel-size", "1e-302"], ["--distance"], 2)]:
    r = run("nebrender", *base, *extra, expect=code)
    left = [n for n in os.listdir(work) if n.startswith("bad")]
    msg = r.stderr.strip().splitlines()[0] if r.stderr.strip() else ""
    blamed = "--wavelengths" in msg and "--wavelengths" not in extra
    check(all(n in msg for n in needles) and not blamed and "planck" not in msg and not left,
          f"refused {' '.join(os.path.basename(e) for e in extra)}: {msg[:140]}")
# --fits-layout tab needs --fits.
r = run("nebrender", "-i", path("lit.vdb"), "-o", path("bad.exr"), "--png", "none", "--camera",
        "orthographic", "--sed", path("bad.csv"), "--fits-layout", "tab", expect=2)
check("--fits-layout" in r.stderr and not [n for n in os.listdir(work) if n.startswith("bad")],
      f"refused --fits-layout tab without --fits: {r.stderr.strip()[:100]}")

if failures:
    print(f"{len(failures)} check(s) failed")
    sys.exit(1)
print("all checks passed")
