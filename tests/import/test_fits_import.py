# SPDX-License-Identifier: Apache-2.0
"""nebimport's FITS input hardened (issue 43): geometry keywords, voxel size and origin ranges,
nearly equal steps, gzip bombs, and damaged headers in nebula's own words.

Every FITS file here is written card by card (so that a card can say what astropy would never
write: BSCALE = 'NaN', CRPIX1 = NaN, BITPIX = 17, a byte above 0x7f), with numpy's data. Each
bad input must exit with its status, one line on stderr naming the file and the keyword, no
cfitsio routine name (ffopen, ffgkyd, ...), no raw byte >= 0x80, and nothing left behind. The
gzip bomb (a header declaring 1000 voxels, then 1 GiB of zeros; about 1 MB gzipped, made here)
must be refused with a small peak memory.

    test_fits_import.py TOOLS_DIR WORK_DIR
"""
import concurrent.futures
import gzip
import os
import re
import shutil
import subprocess
import sys
import time
import zlib

import numpy as np

TOOLS, WORK = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
failures = []
FF = re.compile(rb"\bff[a-z]{3,}\b")


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def card(text):
    raw = text.encode("latin-1") if isinstance(text, str) else text
    assert len(raw) <= 80, text
    return raw.ljust(80, b" ")


def num(key, value):
    return card(f"{key:<8}= {value:>20}")


def fits_bytes(cards, data=None, bitpix=-32, naxes=(8, 8, 8), end=True):
    """A primary HDU: SIMPLE, BITPIX, NAXIS, NAXISn, @p cards, END, then @p data (big-endian)."""
    head = [num("SIMPLE", "T"), num("BITPIX", bitpix), num("NAXIS", len(naxes))]
    head += [num(f"NAXIS{i}", n) for i, n in enumerate(naxes, start=1)]
    head += [card(c) for c in cards]
    if end:
        head.append(card("END"))
    h = b"".join(head)
    h += b" " * (-len(h) % 2880)
    if data is None:
        data = np.ones(tuple(reversed(naxes)), ">f4") if naxes else np.zeros(0, ">f4")
    d = np.ascontiguousarray(data).tobytes()
    return h + d + b"\0" * (-len(d) % 2880)


WCS = ["BUNIT   = 'cm-3'"] + [c for i in (1, 2, 3) for c in (
    f"CTYPE{i}  = '{'XYZ'[i - 1]}'", f"CUNIT{i}  = 'pc'", f"CDELT{i}  = 0.1",
    f"CRPIX{i}  = 1.0", f"CRVAL{i}  = 0.0")]


def with_cards(*extra, drop=()):
    """The good WCS with @p drop keywords left out and @p extra cards added."""
    return [c for c in WCS if c.split("=")[0].strip() not in drop] + list(extra)


def tool(name, *args, cwd=None):
    r = subprocess.run([os.path.join(TOOLS, name), *args], cwd=cwd or WORK, capture_output=True,
                       stdin=subprocess.DEVNULL)
    return r.returncode, r.stderr


def one_clear_line(err, file, words):
    """stderr is one line, naming @p file (unless None) and every one of @p words, in nebula's
    words."""
    lines = err.strip().split(b"\n")
    return (len(lines) == 1 and (file is None or file.encode() in err)
            and all(w.encode() in err for w in words)
            and not FF.search(err) and all(b < 0x80 for b in err))


def refused(what, name, file_bytes, words, code=1, extra=(), suffix=".fits"):
    """Writes @p file_bytes, runs nebimport on it in a folder of its own, checks the refusal."""
    folder = os.path.join(WORK, re.sub(r"[^a-z0-9]+", "_", what.lower()))
    os.makedirs(folder)
    file = name + suffix
    path = os.path.join(folder, file)
    with open(path, "wb") as f:
        f.write(file_bytes)
    c, err = tool("nebimport", "-i", file, *extra, "-o", "out.vdb", cwd=folder)
    left = sorted(set(os.listdir(folder)) - {file})
    ok = c == code and one_clear_line(err, None if code == 2 else file, words) and not left
    return ok, f"{what}: exit {c} (expected {code}), {err.decode('latin-1').strip()!r}, " \
               f"words {words}, left {left}"


shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)
os.chdir(WORK)

cases = []  # (what, name, bytes, words, code, extra, suffix)


def case(what, name, b, words, code=1, extra=(), suffix=".fits"):
    cases.append((what, name, b, words, code, extra, suffix))


# 1. Geometry keywords: finite, in range, cubic and unrotated, or refused naming the keyword.
case("CROTA2 = 30", "crota", fits_bytes(with_cards("CROTA2  = 30.0")), ["CROTA2 = 30", "rotates"])
case("BSCALE = 'NaN'", "bscale_nan", fits_bytes(with_cards("BSCALE  = 'NaN'")),
     ["BSCALE = 'NaN' is not a number"])
case("BSCALE = 0", "bscale_0", fits_bytes(with_cards("BSCALE  = 0.0")), ["BSCALE = 0"])
case("BZERO = 'abc'", "bzero_str", fits_bytes(with_cards("BZERO   = 'abc'")),
     ["BZERO = 'abc' is not a number"])
case("BSCALE = 1e999", "bscale_inf", fits_bytes(with_cards("BSCALE  = 1E999")),
     ["BSCALE = inf", "finite"])
case("CRPIX1 = NaN", "crpix_nan", fits_bytes(with_cards("CRPIX1  = NaN", drop=("CRPIX1",))),
     ["CRPIX1 = NaN is not a number"])
case("CRVAL2 = 'x'", "crval_str", fits_bytes(with_cards("CRVAL2  = 'x'", drop=("CRVAL2",))),
     ["CRVAL2 = 'x' is not a number"])
case("CDELT3 = 1.0.0", "cdelt_bad", fits_bytes(with_cards("CDELT3  = 1.0.0", drop=("CDELT3",))),
     ["CDELT3 = 1.0.0 is not a number"])
case("PC1_2 = 0.5", "pc_shear", fits_bytes(with_cards("PC1_2   = 0.5")), ["PC1_2 = 0.5", "shears"])
case("CDELT 1e300 pc", "cdelt_huge", fits_bytes(
    [c.replace("= 0.1", "= 1E300") for c in WCS]), ["CDELT1..3", "voxels of 1e+300 pc", "expected"])
case("CDELT 1e-9 pc", "cdelt_tiny", fits_bytes(
    [c.replace("= 0.1", "= 1E-9") for c in WCS]), ["CDELT1..3", "voxels of 1e-09 pc", "expected"])
case("CRVAL1 = 1e200 pc", "crval_far", fits_bytes(
    with_cards("CRVAL1  = 1E200", drop=("CRVAL1",))), ["CRPIXn, CRVALn", "1e+200", "at most"])
case("CRPIX1 = -1e15", "crpix_far", fits_bytes(
    with_cards("CRPIX1  = -1E15", drop=("CRPIX1",))),
     ["CRPIXn, CRVALn", "reaches x = 1000000000", "at most 1e+11 pc", "1e+12 voxels of 0.1 pc"])
case("steps 0.1, 0.2, 0.1", "not_cubic", fits_bytes(
    with_cards("CDELT2  = 0.2", drop=("CDELT2",))), ["CDELT1..3", "not cubes"])
np.save("cube.npy", np.ones((4, 4, 4), "<f4"))
npy = open("cube.npy", "rb").read()
case("--voxel-size 1e300pc", "npy_huge", npy, ["--voxel-size", "1e+300 pc", "expected"], code=2,
     extra=("--unit", "cm-3", "--voxel-size", "1e300pc"), suffix=".npy")
case("--origin 1e13 with voxels of 1e-4 pc", "npy_imprecise", npy, ["--origin", "at most"],
     code=2, extra=("--unit", "cm-3", "--voxel-size", "1e-4pc", "--origin", "1e13,0,0"),
     suffix=".npy")
case("--voxel-size 1e-9pc", "npy_tiny", npy, ["--voxel-size", "1e-09 pc", "expected"], code=2,
     extra=("--unit", "cm-3", "--voxel-size", "1e-9pc"), suffix=".npy")

# 5. Damaged headers: cfitsio's status in nebula's words, naming the card and keyword.
good = fits_bytes(WCS)
case("NAXIS1 not a number", "naxis1_str", good.replace(num("NAXIS1", 8), card("NAXIS1  = 'eight'")),
     ["NAXIS1"])
case("BITPIX 17", "bitpix17", fits_bytes(WCS, bitpix=17, data=np.zeros(4, ">f4")),
     ["BITPIX = 17", "expected 8, 16"])
case("BITPIX a string", "bitpix_str", good.replace(num("BITPIX", -32), card("BITPIX  = 'float'")),
     ["BITPIX"])
case("NAXIS 999", "naxis999", good.replace(num("NAXIS", 3), num("NAXIS", 999)),
     ["NAXIS4"])
case("NAXIS 1000", "naxis1000", good.replace(num("NAXIS", 3), num("NAXIS", 1000)), ["NAXIS = 1000"])
case("NAXIS2 negative", "naxis2_neg", good.replace(num("NAXIS2", 8), num("NAXIS2", -5)),
     ["NAXIS2 = -5"])
case("truncated header", "trunc_head", good[:800], ["no END card"])
case("no END card", "no_end", fits_bytes(WCS, end=False), ["no END card"])
case("no END card, text after", "no_end_text", fits_bytes(WCS, end=False, data=np.full(
    (8, 8, 8), 0x20202020, ">u4")), ["no END card"])
case("SIMPLE = F", "simple_f", good.replace(num("SIMPLE", "T"), num("SIMPLE", "F")),
     ["SIMPLE = F"])
case("not SIMPLE first", "no_simple", good.replace(num("SIMPLE", "T"), num("SIMPLX", "T")),
     ["card 1 is SIMPLX"])
case("non-ASCII byte in a value", "non_ascii",
     good.replace(card("BUNIT   = 'cm-3'"), card(b"BUNIT   = 'cm-3\xe9'")),
     ["card 7 (BUNIT)", "\\xe9"])
case("non-ASCII byte in a keyword", "non_ascii_key",
     good.replace(card("CTYPE1  = 'X'"), card(b"CTYP\xc31  = 'X'")), ["card 8", "\\xc3"])
case("a control byte in a comment", "control",
     good.replace(card("CTYPE1  = 'X'"), card(b"CTYPE1  = 'X' / \x1b[2J")), ["card 8", "\\x1b"])
case("string with no closing quote", "no_quote",
     good.replace(card("CTYPE1  = 'X'"), card("CTYPE1  = 'X")), ["CTYPE1", "no closing quote"])
case("a keyword with a blank in it", "key_blank",
     good.replace(card("CTYPE1  = 'X'"), card("CTY E1  = 'X'")), ["CTY E1", "character"])
case("END card not blank", "end_junk", good.replace(card("END"), card("END     junk")),
     ["END card is not blank"])
case("data cut short", "trunc_data", good[:2880 + 100], ["truncated"])
case("not FITS at all", "text", b"hello, world\n" * 300, ["card 1"])
ext = fits_bytes([], naxes=()) + fits_bytes(WCS, bitpix=17).replace(
    num("SIMPLE", "T"), card("XTENSION= 'IMAGE   '"))
case("an extension's BITPIX 17", "ext_bitpix", ext, ["HDU 1", "BITPIX = 17"])


def gz(b, level=6):
    return gzip.compress(b, compresslevel=level)


# 4. gzip: a legitimate file reads as the plain one; a truncated or damaged one is refused.
case("truncated .fits.gz", "trunc_gz", gz(good)[:len(gz(good)) // 2], ["truncated"],
     suffix=".fits.gz")
bad_gz = bytearray(gz(good))
bad_gz[20:40] = b"\xff" * 20
case("damaged .fits.gz", "bad_gz", bytes(bad_gz), ["gzip data is damaged"], suffix=".fits.gz")
case("gzipped damaged header", "gz_bitpix", gz(fits_bytes(WCS, bitpix=17)), ["BITPIX = 17"],
     suffix=".fits.gz")

with concurrent.futures.ThreadPoolExecutor(max_workers=4) as pool:
    for ok, what in pool.map(lambda c: refused(*c), cases):
        check(ok, what)

# 3. Nearly equal steps: snapped to one voxel size, -v says so, nebstats then accepts the file.
near = [c.replace("CDELT2  = 0.1", "CDELT2  = 0.1000000003").replace(
    "CDELT3  = 0.1", "CDELT3  = 0.0999999998") for c in WCS]
rng = np.random.default_rng(43)
cube = (rng.random((8, 8, 8)) + 1).astype(">f4")
open("near.fits", "wb").write(fits_bytes(near, data=cube))
c, err = tool("nebimport", "-v", "-i", "near.fits", "-o", "near.vdb")
check(c == 0 and b"CDELT1..3 differ by 3e-09 relative; voxels taken as cubes of 0.1 pc" in err,
      f"nearly equal steps snapped, -v says so: exit {c}, {err.decode('latin-1')!r}")
c, err = tool("nebstats", "-i", "near.vdb")
check(c == 0, f"nebstats accepts the snapped file: exit {c}, {err.decode('latin-1')!r}")
c, err = tool("nebimport", "-i", "near.fits", "-o", "quiet.vdb")
check(c == 0 and err == b"", f"without -v the snap is silent: {err!r}")

# A legitimate .fits.gz: the same grid as the plain file.
open("plain.fits", "wb").write(fits_bytes(WCS, data=cube))
open("plain.fits.gz", "wb").write(gz(fits_bytes(WCS, data=cube)))
for name in ("plain.fits", "plain.fits.gz"):
    c, err = tool("nebimport", "-i", name, "-o", name + ".vdb")
    check(c == 0, f"{name} imports: exit {c}, {err!r}")
    c, err = tool("nebexport", "-i", name + ".vdb", "-o", name + ".npy")
    check(c == 0, f"{name} exports: exit {c}, {err!r}")
check(np.array_equal(np.load("plain.fits.npy"), np.load("plain.fits.gz.npy")) and
      np.array_equal(np.load("plain.fits.npy"), cube.T.astype("<f4")),
      ".fits.gz reads as the plain file, bit for bit")

# The bomb: a valid header declaring 10^3 voxels (4000 bytes), then 1 GiB of zeros, gzipped
# here as a stream (about 1 MB). Unbounded, it would take 1 GiB of memory.
bomb_head = fits_bytes(WCS, data=np.zeros((10, 10, 10), ">f4"), naxes=(10, 10, 10))
with open("bomb.fits.gz", "wb") as f:
    z = zlib.compressobj(1, zlib.DEFLATED, 16 + zlib.MAX_WBITS)
    f.write(z.compress(bomb_head))
    zeros = bytes(1 << 24)
    for _ in range(64):
        f.write(z.compress(zeros))
    f.write(z.flush())
os.makedirs("bomb")
start = time.monotonic()
r = subprocess.run([sys.executable, "-c", (
    "import resource, subprocess, sys\n"
    "r = subprocess.run(sys.argv[1:], capture_output=True)\n"
    "sys.stderr.buffer.write(r.stderr)\n"
    "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n"
    "sys.exit(r.returncode)"), os.path.join(TOOLS, "nebimport"), "-i", "../bomb.fits.gz", "-o",
    "out.vdb"], cwd="bomb", capture_output=True)
seconds = time.monotonic() - start
peak_mib = int(r.stdout.decode().strip() or 0) / 1024
check(r.returncode == 1 and one_clear_line(r.stderr, "bomb.fits.gz", ["inflates to at least",
                                                                       "declare 8640 bytes"])
      and not os.listdir("bomb") and peak_mib < 256 and seconds < 30,
      f"gzip bomb ({os.path.getsize('bomb.fits.gz')} bytes, 1 GiB inflated) refused: exit "
      f"{r.returncode}, {r.stderr.decode('latin-1').strip()!r}, peak {peak_mib:.0f} MiB, "
      f"{seconds:.1f} s")

if failures:
    print(f"test_fits_import: FAIL: {len(failures)} checks failed")
    sys.exit(1)
print("test_fits_import: PASS")
