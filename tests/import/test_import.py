# SPDX-License-Identifier: Apache-2.0
"""nebimport and nebexport end to end, against astropy, h5py and numpy (DESIGN section 10).

Cubes written by the other programs (FITS with BUNIT and a WCS, HDF5 with a units attribute,
.npy in Fortran order and big-endian) are imported and exported back: the values must come back
bit for bit and the FITS WCS equal (CDELT, CRPIX, CRVAL, CUNIT); units are converted; each bad
input is refused with its message, exit status 1 or 2, and no output left behind.

    test_import.py TOOLS_DIR WORK_DIR
"""
import concurrent.futures
import os
import shutil
import subprocess
import sys

import h5py
import numpy as np
from astropy.io import fits
from astropy.wcs import WCS

TOOLS, WORK = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def tool(name, *args):
    r = subprocess.run([os.path.join(TOOLS, name), *args], cwd=WORK, capture_output=True,
                       text=True, stdin=subprocess.DEVNULL)
    return r.returncode, r.stderr


def run_ok(name, *args):
    code, err = tool(name, *args)
    check(code == 0, f"{name} {' '.join(args)}" + ("" if code == 0 else f": exit {code}: {err}"))


pending = []  # the refusals, run side by side at the end (each in its own folder)


def refused(what, name, args, message, output="out.vdb"):
    pending.append((what, name, args, message, output))


def run_refusal(index, what, name, args, message, output):
    folder = os.path.join(WORK, f"refused{index}")
    os.makedirs(folder)
    # Inputs are the files made above; outputs land in the case's own, empty folder.
    args = [os.path.join(WORK, a) if os.path.exists(os.path.join(WORK, a)) else a for a in args]
    r = subprocess.run([os.path.join(TOOLS, name), *args], cwd=folder, capture_output=True,
                       text=True, stdin=subprocess.DEVNULL)
    left = os.listdir(folder)
    return (r.returncode in (1, 2) and message in r.stderr and not left,
            f"{what}: exit {r.returncode}, message {message!r} in {r.stderr.strip()!r}, "
            f"left {left}")


def bits(a):
    return np.ascontiguousarray(a, dtype="<f4").view("<u4")


shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)
os.chdir(WORK)

# A sparse-ish cloud: zeros (inactive) around clumps, values of every size.
rng = np.random.default_rng(25)
a = (rng.lognormal(0, 2, size=(20, 24, 28)) * (rng.random((20, 24, 28)) < 0.4)).astype("<f4")
a[0, 0, 0] = 1e-30
a[19, 23, 27] = 3e7

# FITS by astropy: data[z, y, x] = a.T, BUNIT and a WCS in au.
hdu = fits.PrimaryHDU(a.T)
hdu.header["BUNIT"] = "cm-3"
for i, (crpix, crval) in enumerate([(1.0, 0.0), (12.5, 100.0), (-3.0, 2.5e3)], start=1):
    hdu.header[f"CTYPE{i}"] = "XYZ"[i - 1]
    hdu.header[f"CUNIT{i}"] = "au"
    hdu.header[f"CDELT{i}"] = 250.0
    hdu.header[f"CRPIX{i}"] = crpix
    hdu.header[f"CRVAL{i}"] = crval
hdu.writeto("a.fits")


def fits_round_trip():
    run_ok("nebimport", "-i", "a.fits", "-o", "a_fits.vdb")
    run_ok("nebexport", "-i", "a_fits.vdb", "-o", "back.fits")
    b = fits.getdata("back.fits").T
    check(b.shape == a.shape and np.array_equal(bits(b), bits(a)), "FITS round trip bit for bit")
    h0, h1 = fits.getheader("a.fits"), fits.getheader("back.fits")
    check(all(h0[f"{k}{i}"] == h1[f"{k}{i}"] for k in ("CDELT", "CRPIX", "CRVAL", "CUNIT")
              for i in (1, 2, 3)), "FITS WCS keywords equal")
    check(WCS(h0).wcs.compare(WCS(h1).wcs), "FITS WCS equal (astropy)")
    check(h1["BUNIT"] == "cm-3" and any("nebimport" in str(x) for x in h1["HISTORY"]),
          "FITS BUNIT and HISTORY")
    # A part of the cube: the imported WCS, its CRPIX moved by the box's offset.
    run_ok("nebexport", "-i", "a_fits.vdb", "--bbox", "2,3,4,10,11,12", "-o", "part.fits")
    hp = fits.getheader("part.fits")
    world0 = WCS(h0).pixel_to_world_values(2, 3, 4)  # 0-based pixels of the original
    worldp = WCS(hp).pixel_to_world_values(0, 0, 0)
    check(hp["CUNIT1"] == "au" and np.allclose(world0, worldp, rtol=1e-12, atol=1e-9),
          "FITS WCS of a part of the cube: its first voxel where it was")
    check(np.array_equal(bits(fits.getdata("part.fits").T), bits(a[2:11, 3:12, 4:13])),
          "FITS part of the cube")


# HDF5 by h5py, with a units attribute and the geometry.
def hdf5_round_trip():
    with h5py.File("a.h5", "w") as f:
        d = f.create_dataset("/sim/gas/rho", data=a)
        d.attrs["units"] = "cm-3"
        d.attrs["voxel_size_pc"] = 0.02
        d.attrs["origin_pc"] = [1.0, -2.0, 3.5]
        f.create_dataset("/other", data=np.zeros((3, 3, 3)))
    run_ok("nebimport", "-i", "a.h5", "--dataset", "/sim/gas/rho", "-o", "a_h5.vdb")
    run_ok("nebexport", "-i", "a_h5.vdb", "-o", "back.h5")
    with h5py.File("back.h5") as f:
        d = f["density"]
        check(np.array_equal(bits(d[...]), bits(a)), "HDF5 round trip bit for bit")
        check(d.attrs["units"] == "cm-3" and np.array_equal(d.attrs["voxel_size_pc"], [0.02])
              and np.array_equal(d.attrs["origin_pc"], [1.0, -2.0, 3.5]), "HDF5 attributes equal")



# numpy: Fortran order, big-endian, float64 and integers.
def npy_round_trips():
    np.save("a_f.npy", np.asfortranarray(a))
    np.save("a_be.npy", a.astype(">f4"))
    np.save("a_f8.npy", a.astype(">f8"))
    np.save("a_i.npy", np.arange(2 * 3 * 4, dtype="<i2").reshape(2, 3, 4))
    for name in ("a_f", "a_be", "a_f8"):
        run_ok("nebimport", "-i", f"{name}.npy", "--unit", "cm-3", "--voxel-size", "0.1pc", "-o",
               f"{name}.vdb")
        run_ok("nebexport", "-i", f"{name}.vdb", "-o", f"{name}_back.npy")
        check(np.array_equal(bits(np.load(f"{name}_back.npy")), bits(a)), f"{name}.npy round trip")
    run_ok("nebimport", "-i", "a_i.npy", "--unit", "cm-3", "--voxel-size", "0.1pc", "-o", "a_i.vdb")
    run_ok("nebexport", "-i", "a_i.vdb", "-o", "a_i_back.npy")
    check(np.array_equal(np.load("a_i_back.npy"), np.arange(24).reshape(2, 3, 4)),
          "integer .npy imported (zero stays inactive, exported as 0)")



# Units: g/cm3 gas with --mu, Msun/pc3; a cube's own unit that disagrees with --unit.
def units():
    m_h = 1.00782503223 * 1.66053906660e-24
    np.save("rho.npy", a.astype("<f8") * 1.4 * m_h)
    run_ok("nebimport", "-i", "rho.npy", "--unit", "g/cm3", "--voxel-size", "1pc", "-o", "rho.vdb")
    run_ok("nebexport", "-i", "rho.vdb", "-o", "rho_back.npy")
    check(np.allclose(np.load("rho_back.npy"), a, rtol=2e-7, atol=0), "g/cm3 -> n_H with mu 1.4")
    np.save("msun.npy", np.ones((2, 2, 2), "<f4"))
    run_ok("nebimport", "-i", "msun.npy", "--unit", "Msun/pc3", "--voxel-size", "1pc", "-o", "m.vdb")
    run_ok("nebexport", "-i", "m.vdb", "-o", "m_back.npy")
    check(abs(np.load("m_back.npy")[0, 0, 0] - 28.89) < 0.01, "1 Msun/pc3 = 28.89 cm^-3 at mu 1.4")
    hdu = fits.PrimaryHDU(a.T)
    hdu.header["BUNIT"] = "g/cm3"
    hdu.writeto("gcm3.fits")
    refused("unit mismatch", "nebimport", ["-i", "gcm3.fits", "--unit", "cm-3", "--voxel-size",
                                           "1pc", "-o", "out.vdb"], "the file says its unit is")



# Temperature and velocity (one 4-D array, leading axis of 3) on the density's voxels, then
# the pipeline: nebillum reads the star and nebexport writes tau.
def spectral_and_pipeline():
    np.save("t.npy", np.full(a.shape, 5000, "<f4"))
    np.save("v.npy", np.stack([np.full(a.shape, c, "<f4") for c in (1, -2, 3)]))
    run_ok("nebimport", "-i", "a.fits", "--temperature", "t.npy", "--velocity", "v.npy",
           "--star", "s:0,0,0:100:B5V", "-o", "spec.vdb")
    run_ok("nebexport", "-i", "spec.vdb", "--grid", "temperature", "-o", "t_back.npy")
    check(np.array_equal(np.load("t_back.npy"), np.where(a > 0, 5000, 0).astype("f4")),
          "temperature on the density's active voxels")
    code, _ = tool("nebillum", "-i", "spec.vdb", "-o", "lit.vdb")
    check(code == 0, "nebillum reads an imported cube")
    run_ok("nebexport", "-i", "lit.vdb", "--grid", "tau.s", "--bbox", "active", "-o", "tau.fits")
    check(fits.getheader("tau.fits")["BUNIT"] == "", "tau has no unit")



# The cases side by side: each runs its tools in order, on files of its own.
with concurrent.futures.ThreadPoolExecutor(max_workers=4) as pool:
    for job in [pool.submit(f) for f in (fits_round_trip, hdf5_round_trip, npy_round_trips,
                                         units, spectral_and_pipeline)]:
        job.result()

# Bad inputs: each refused, naming the file or option, nothing left behind.
vox = ["--unit", "cm-3", "--voxel-size", "1pc", "-o", "out.vdb"]
nan = a.copy()
nan[3, 4, 5] = np.nan
np.save("nan.npy", nan)
refused("NaN", "nebimport", ["-i", "nan.npy", *vox], "nan.npy: density at voxel (3, 4, 5) is nan")
neg = a.copy()
neg[1, 2, 3] = -1
np.save("neg.npy", neg)
refused("negative", "nebimport", ["-i", "neg.npy", *vox], "is -1, expected >= 0")
fits.PrimaryHDU(np.ones((8, 8), "f4")).writeto("flat.fits")
refused("2-D image", "nebimport", ["-i", "flat.fits", *vox], "a 2-D image (8 x 8)")
hdr = fits.Header()
for k, v in [("SIMPLE", True), ("BITPIX", -32), ("NAXIS", 3), ("NAXIS1", 1000000),
             ("NAXIS2", 1000000), ("NAXIS3", 1)]:
    hdr[k] = v
hdr.tofile("huge.fits")
refused("10^6 x 10^6 x 1", "nebimport", ["-i", "huge.fits", *vox], "at most 2^36")
with h5py.File("huge.h5", "w") as f:
    f.create_dataset("rho", shape=(1000000, 1000000, 1), dtype="f4", chunks=(1, 1000, 1))
refused("10^6 x 10^6 x 1 HDF5", "nebimport", ["-i", "huge.h5", *vox], "at most 2^36")
refused("HDF5 path", "nebimport", ["-i", "a.h5", "--dataset", "/sim/gas/nope", *vox],
        'no dataset "/sim/gas/nope"')
good = open("a.fits", "rb").read()
open("trunc.fits", "wb").write(good[:len(good) // 2])
refused("truncated FITS", "nebimport", ["-i", "trunc.fits", *vox], "truncated")
damaged = bytearray(good)
damaged[80 * 3 + 10:80 * 3 + 30] = b"     not a number   "
open("damaged.fits", "wb").write(bytes(damaged))
refused("damaged FITS header", "nebimport", ["-i", "damaged.fits", *vox],
        "damaged.fits: cannot open it as a FITS file")
np.save("object.npy", np.array([None, 1, "x"], dtype=object), allow_pickle=True)
refused("object dtype", "nebimport", ["-i", "object.npy", *vox], "object array")
raw = open("a_f.npy", "rb").read()
open("short.npy", "wb").write(raw[:len(raw) - 100])
refused("npy shorter than its header says", "nebimport", ["-i", "short.npy", *vox],
        "truncated: the header says 53760 bytes of data")
os.makedirs("radmc")
with open("radmc/amr_grid.inp", "w") as f:
    f.write("1\n0\n0\n0\n1 1 1\n2 2 2\n" + "0\n1e17\n2e17\n" * 3)
with open("radmc/dust_density.inp", "w") as f:
    f.write("1\n9\n1\n" + "1e-20\n" * 9)
refused("RADMC cell counts", "nebimport", ["-i", "radmc", "-o", "out.vdb"],
        "9 cells, but amr_grid.inp has 2 x 2 x 2 = 8")
refused("unknown unit", "nebimport", ["-i", "a_f.npy", "--unit", "furlongs", "--voxel-size",
                                      "1pc", "-o", "out.vdb"], '--unit: unknown density unit')
refused("no unit", "nebimport", ["-i", "a_f.npy", "--voxel-size", "1pc", "-o", "out.vdb"],
        "give --unit")
refused("zero voxel", "nebimport", ["-i", "a_f.npy", "--unit", "cm-3", "--voxel-size", "0pc",
                                    "-o", "out.vdb"], "--voxel-size")
refused("negative voxel", "nebimport", ["-i", "a_f.npy", "--unit", "cm-3", "--voxel-size",
                                        "-2au", "-o", "out.vdb"], "--voxel-size")
refused("missing grid", "nebexport", ["-i", "a_fits.vdb", "--grid", "nope", "-o", "out.fits"],
        '"nope"', output="out.fits")
refused("a FITS cube larger than memory", "nebexport",
        ["-i", "a_fits.vdb", "--bbox", "0,0,0,4094,4094,4094", "-o", "out.fits"],
        "of memory; this machine has", output="out.fits")
refused("a cube of more than 2^36 voxels", "nebexport",
        ["-i", "a_fits.vdb", "--bbox", "0,0,0,9999,9999,9999", "-o", "out.npy"],
        "more than the 2^36", output="out.npy")
refused("unknown extension", "nebexport", ["-i", "a_fits.vdb", "-o", "out.txt"], "--format",
        output="out.txt")

with concurrent.futures.ThreadPoolExecutor(max_workers=4) as pool:
    for ok, what in pool.map(lambda job: run_refusal(job[0], *job[1]), enumerate(pending)):
        check(ok, what)

if failures:
    print(f"test_import: FAIL: {len(failures)} checks failed")
    sys.exit(1)
print("test_import: PASS")
