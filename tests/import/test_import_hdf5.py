# SPDX-License-Identifier: Apache-2.0
"""nebimport's HDF5 reader against hostile and odd files written by h5py (DESIGN section 10).

No file may make nebimport read a file the user did not name: external raw-data storage,
external and soft links on the dataset's path and virtual datasets are refused by name before
any value is read (their targets are FIFOs here, so a read would hang the run: each case has a
time limit); filters this build lacks or cannot bound, datasets with no stored values, chunks
that would inflate past their size or need more memory than the cube are refused; the
attributes are checked (fixed-length units strings, voxel_size_pc, origin_pc). Each refusal:
exit status 1 (2 for a choice the user must make), one line naming the file, the dataset and
the feature, nothing left behind. The files that are good import with the right values.

    test_import_hdf5.py TOOLS_DIR WORK_DIR
"""
import concurrent.futures
import os
import shutil
import subprocess
import sys
import time
import zlib

import h5py
import numpy as np

TOOLS, WORK = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def nebimport(args, cwd, timeout=60):
    start = time.monotonic()
    try:
        r = subprocess.run([os.path.join(TOOLS, "nebimport"), *args], cwd=cwd,
                           capture_output=True, text=True, stdin=subprocess.DEVNULL,
                           timeout=timeout)
        return r.returncode, r.stderr, time.monotonic() - start
    except subprocess.TimeoutExpired:
        return None, "(timed out: it read a FIFO or hung)", time.monotonic() - start


# libhdf5 loops on one file below: its structure walk is cut after 10 s, not the default 120
# (a good file's walk takes milliseconds).
os.environ["NEBULA_HDF5_PROBE_SECONDS"] = "10"
shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)
os.chdir(WORK)
cube = (np.arange(5 * 6 * 7, dtype="<f4").reshape(5, 6, 7) % 11) * 0.25
good_attrs = {"units": "cm-3", "voxel_size_pc": 0.5}


def write(name, data=cube, attrs=good_attrs, dataset="density", **kw):
    with h5py.File(name, "w") as f:
        d = f.create_dataset(dataset, data=data, **kw)
        for k, v in attrs.items():
            d.attrs[k] = v


# Files that must not be read: FIFOs (open() for reading blocks until a writer comes).
os.mkfifo("fifo.h5")
os.mkfifo("fifo.bin")

cases = []  # (what, file, extra args, expected exit, [message parts], time limit [s])


# The unit and voxel size given, so that nothing else stops the run before the feature tested.
GIVEN = ["--unit", "cm-3", "--voxel-size", "1pc"]


def refused(what, name, parts, extra=(), code=1, limit=30, given=GIVEN):
    cases.append((what, name, [*extra, *given], code, parts, limit))


# External raw-data storage: an absolute path and one relative to the working folder.
with h5py.File("ext-abs.h5", "w") as f:
    f.create_dataset("density", shape=(4, 4, 4), dtype="u1", external=[("/etc/passwd", 0, 64)])
refused("external storage (/etc/passwd)", "ext-abs.h5",
        ["ext-abs.h5: dataset /density keeps its values in another file", '"/etc/passwd"',
         "external storage"])
with h5py.File("ext-rel.h5", "w") as f:
    f.create_dataset("density", shape=(4, 4, 4), dtype="<f4", external=[("fifo.bin", 0, 256)])
refused("external storage (relative path, a FIFO)", "ext-rel.h5",
        ["ext-rel.h5: dataset /density keeps its values in another file", '"fifo.bin"'])

# Links: an external link (to a FIFO), a group reached through one, a soft link.
with h5py.File("elink.h5", "w") as f:
    f["density"] = h5py.ExternalLink("fifo.h5", "/density")
    f["grp"] = h5py.ExternalLink("fifo.h5", "/")
refused("external link named by --dataset", "elink.h5",
        ["elink.h5: dataset /density: /density is an external link", '"fifo.h5"'],
        ["--dataset", "/density"])
refused("a --dataset path that crosses an external link", "elink.h5",
        ["elink.h5: dataset /grp/density: /grp is an external link", '"fifo.h5"'],
        ["--dataset", "grp/density"])
refused("only an external link: nothing chosen", "elink.h5",
        ["elink.h5: no 3-D dataset", "/density (an external link", "not followed"], code=2)
with h5py.File("soft.h5", "w") as f:
    f.create_dataset("real/density", data=cube)
    f["density"] = h5py.SoftLink("/real/density")
refused("soft link", "soft.h5",
        ["soft.h5: dataset /density: /density is a soft link", '"/real/density"'],
        ["--dataset", "/density"])

# A virtual dataset whose source is a FIFO.
layout = h5py.VirtualLayout(shape=cube.shape, dtype="<f4")
layout[:] = h5py.VirtualSource("fifo.h5", "density", shape=cube.shape)
with h5py.File("vds.h5", "w") as f:
    f.create_virtual_dataset("density", layout, fillvalue=0)
refused("virtual dataset (chosen as the only cube)", "vds.h5",
        ["vds.h5: dataset /density is a virtual dataset"])
refused("virtual dataset (named)", "vds.h5", ["vds.h5: dataset /density is a virtual dataset"],
        ["--dataset", "/density"])

# No stored values: 4096^3 declared, nothing written (contiguous, and chunked). Refused in well
# under a second: timed alone below, against a refusal that reads nothing (a missing file).
with h5py.File("unwritten.h5", "w") as f:
    f.create_dataset("density", shape=(4096, 4096, 4096), dtype="<f4")
refused("unwritten 4096^3 contiguous", "unwritten.h5",
        ["unwritten.h5: dataset /density has no stored values", "4096 x 4096 x 4096"])
with h5py.File("unwritten-chunked.h5", "w") as f:
    f.create_dataset("density", shape=(4096, 4096, 4096), dtype="<f4", chunks=(64, 64, 64),
                     compression="gzip")
refused("unwritten 4096^3 chunked", "unwritten-chunked.h5",
        ["unwritten-chunked.h5: dataset /density has no stored values"])

# A filter libhdf5 lacks (h5py's own LZF; nebimport's libhdf5 has no plugin for it).
write("lzf.h5", compression="lzf", chunks=(5, 6, 7))
refused("LZF", "lzf.h5", ["lzf.h5: dataset /density is", "filter 32000 (lzf)",
                          "save it with gzip or without compression"], given=[])

# Gzip bombs: a chunk of 64^3 floats (1 MiB) holding 64 MiB of zeros in 65 KB, and a chunk of
# 4x4x4 floats (256 bytes) stored in more bytes than it holds.
with h5py.File("bomb.h5", "w") as f:
    d = f.create_dataset("density", shape=(64, 64, 64), dtype="<f4", chunks=(64, 64, 64),
                         compression="gzip")
    d.id.write_direct_chunk((0, 0, 0), zlib.compress(bytes(64 << 20), 9))
    d.attrs.update(good_attrs)
refused("gzip bomb", "bomb.h5",
        ["bomb.h5: dataset /density: a chunk inflates to more than its 1048576 bytes"], given=[])
with h5py.File("bomb-small.h5", "w") as f:
    d = f.create_dataset("density", shape=(4, 4, 4), dtype="<f4", chunks=(4, 4, 4),
                         compression="gzip")
    d.id.write_direct_chunk((0, 0, 0), zlib.compress(bytes(4 << 20), 9))
    d.attrs.update(good_attrs)
refused("a chunk stored in more bytes than it holds", "bomb-small.h5",
        ["bomb-small.h5: dataset /density: damaged: a chunk is stored in",
         "more than its 256 bytes of values"], given=[])

# Chunks far larger than the cube (allowed by HDF5 for a resizable dataset): 1 GB each.
with h5py.File("bigchunk.h5", "w") as f:
    d = f.create_dataset("density", data=cube[:2, :2, :2], maxshape=(None, None, None),
                         chunks=(1024, 1024, 256), compression="gzip")
    d.attrs.update(good_attrs)
refused("chunks of 1 GB for a 2x2x2 cube", "bigchunk.h5",
        ["bigchunk.h5: dataset /density: its chunks of 1024 x 1024 x 256",
         "save it with smaller chunks"], given=[])

# A flipped bit in a chunk with a checksum (gzip + fletcher32).
write("flipped.h5", chunks=(5, 6, 7), compression="gzip", fletcher32=True)
with h5py.File("flipped.h5", "r") as f:
    info = f["density"].id.get_chunk_info(0)
with open("flipped.h5", "r+b") as f:
    f.seek(info.byte_offset + info.size // 2)
    byte = f.read(1)
    f.seek(info.byte_offset + info.size // 2)
    f.write(bytes([byte[0] ^ 0x10]))
refused("a flipped bit under fletcher32", "flipped.h5",
        ["flipped.h5: dataset /density: damaged: a chunk does not match its checksum"], given=[])

# Attributes.
for what, value, shown in [("negative", -0.1, "-0.1"), ("non-cubic", [0.1, 0.2, 0.1],
                                                         "[0.1, 0.2, 0.1]"),
                           ("NaN", float("nan"), "nan"), ("infinite", float("inf"), "inf"),
                           ("zero", 0.0, "0")]:
    name = f"voxel-{what}.h5"
    write(name, attrs={"units": "cm-3", "voxel_size_pc": value})
    refused(f"voxel_size_pc {what}", name,
            [f"{name}: dataset /density: attribute voxel_size_pc is {shown}",
             "expected one finite positive number [pc] or three equal ones"], given=[])
write("origin-nan.h5", attrs={"units": "cm-3", "voxel_size_pc": 0.5,
                              "origin_pc": [0.0, float("nan"), 1.0]})
refused("origin_pc NaN", "origin-nan.h5",
        ["origin-nan.h5: dataset /density: attribute origin_pc is [0, nan, 1]",
         "3 finite numbers"], given=[])


# Files on which libhdf5 1.10 itself crashes or loops (tests/fuzz/libhdf5): the structure is
# walked in a child process first, so the tool refuses them instead of dying or hanging.
LIBHDF5 = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "fuzz", "libhdf5")
for crash in ("bad-free-in-link-table.h5", "null-read-in-metadata-accumulator.h5",
              "endless-loop-in-global-heap.h5"):
    shutil.copy(os.path.join(LIBHDF5, crash), crash)
    refused(f"libhdf5 fails on {crash}", crash,
            [f"{crash}: the HDF5 library", "the file is damaged or hostile; nothing was read"],
            limit=40)


def run_case(index, case):
    what, name, extra, code, parts, limit = case
    folder = os.path.join(WORK, f"case{index}")
    os.makedirs(folder)
    got, err, seconds = nebimport(["-i", os.path.join(WORK, name), *extra, "-o", "out.vdb"],
                                  folder, timeout=max(limit, 20))
    left = os.listdir(folder)
    lines = err.strip().splitlines()
    ok = (got == code and all(p in err for p in parts) and len(lines) == 1 and not left
          and seconds < limit and "H5" not in err and os.path.exists(os.path.join(WORK, name)))
    return ok, (f"{what}: exit {got} (want {code}), {seconds:.2f} s (limit {limit}), "
                f"message {err.strip()!r}, want {parts}, left {left}")


# The good files: values and units right.
def imports(what, name, args, want):
    folder = os.path.join(WORK, "good-" + name.replace(".h5", ""))
    os.makedirs(folder)
    got, err, _ = nebimport(["-i", os.path.join(WORK, name), *args, "-o", "out.vdb"], folder)
    if got != 0:
        check(False, f"{what}: exit {got}: {err.strip()}")
        return
    r = subprocess.run([os.path.join(TOOLS, "nebexport"), "-i", "out.vdb", "-o", "out.npy",
                        "--bbox", "0,0,0,{},{},{}".format(*(n - 1 for n in want.shape))],
                       cwd=folder, capture_output=True, text=True)
    if r.returncode != 0:
        check(False, f"{what}: nebexport: {r.stderr.strip()}")
        return
    back = np.load(os.path.join(folder, "out.npy"))
    check(back.shape == want.shape and np.allclose(back, want, rtol=1e-6, atol=0),
          f"{what}: values equal ({back.shape} vs {want.shape}, max difference "
          f"{np.max(np.abs(back - want)) if back.shape == want.shape else 'n/a'})")


# Fixed-length units strings: NULLPAD (numpy bytes, h5py's fixed strings), NULLTERM, SPACEPAD.
write("units-nullpad.h5", attrs={"units": np.bytes_("cm-3"), "voxel_size_pc": 0.5})
for pad, tag in [(h5py.h5t.STR_NULLTERM, "nullterm"), (h5py.h5t.STR_SPACEPAD, "spacepad")]:
    write(f"units-{tag}.h5", attrs={"voxel_size_pc": 0.5})
    with h5py.File(f"units-{tag}.h5", "a") as f:
        t = h5py.h5t.C_S1.copy()
        t.set_size(8)
        t.set_strpad(pad)
        space = h5py.h5s.create(h5py.h5s.SCALAR)
        a = h5py.h5a.create(f["density"].id, b"units", t, space)
        a.write(np.array(b"cm-3" + (b" " * 4 if tag == "spacepad" else b""), dtype="S8"))
# A density in g/cm3 stays g/cm3 -> n_H = rho / (mu m_H): the unit was read whole.
write("units-gcm3.h5", attrs={"units": np.array(b"g/cm3", dtype="S5"), "voxel_size_pc": 0.5},
      data=cube * 1e-24)
# gzip + shuffle + fletcher32 in chunks across the edges, one chunk never written (fill 0.5),
# and big-endian int16 values.
with h5py.File("gzip.h5", "w") as f:
    d = f.create_dataset("sim/rho", shape=cube.shape, dtype="<f4", chunks=(2, 4, 3),
                         compression="gzip", shuffle=True, fletcher32=True, fillvalue=0.5)
    d[:4] = cube[:4]
    d.attrs.update(good_attrs)
write("shuffle.h5", chunks=(3, 6, 4), shuffle=True)
partly = cube.copy()
partly[4:] = 0.5
with h5py.File("int16.h5", "w") as f:
    d = f.create_dataset("n", data=(cube * 4).astype(">i2"), chunks=(1, 6, 7))
    f.attrs.update(good_attrs)

with concurrent.futures.ThreadPoolExecutor(max_workers=4) as pool:
    for ok, what in pool.map(lambda job: run_case(*job), enumerate(cases)):
        check(ok, what)
    jobs = [pool.submit(imports, "fixed-length NULLPAD units (cm-3)", "units-nullpad.h5", [],
                        cube),
            pool.submit(imports, "fixed-length NULLTERM units", "units-nullterm.h5", [], cube),
            pool.submit(imports, "fixed-length SPACEPAD units", "units-spacepad.h5", [], cube),
            pool.submit(imports, "fixed-length g/cm3", "units-gcm3.h5", ["--mu", "1"],
                        cube * 1e-24 / (1.00782503223 * 1.66053906660e-24)),
            pool.submit(imports, "gzip, shuffle, fletcher32, a chunk not written", "gzip.h5",
                        [], partly),
            pool.submit(imports, "big-endian int16 in chunks", "int16.h5", [], cube * 4),
            pool.submit(imports, "shuffle without compression", "shuffle.h5", [], cube)]
    for job in jobs:
        job.result()

# Time: the unwritten 4096^3 datasets against a refusal that opens nothing, one at a time.
base = min(nebimport(["-i", "missing.h5", "-o", "out.vdb"], WORK)[2] for _ in range(3))
for name in ("unwritten.h5", "unwritten-chunked.h5"):
    got, err, seconds = min((nebimport(["-i", name, *GIVEN, "-o", "out.vdb"], WORK, timeout=20)
                             for _ in range(3)), key=lambda r: r[2])
    check(got == 1 and seconds < base + 0.5,
          f"{name}: refused in {seconds:.2f} s, a missing file in {base:.2f} s (at most 0.5 s "
          "more)")
check(not os.path.exists("out.vdb"), "no output left")

# The FIFOs were never opened for reading (a writer would now find no reader).
for fifo in ("fifo.h5", "fifo.bin"):
    try:
        fd = os.open(fifo, os.O_WRONLY | os.O_NONBLOCK)
        os.close(fd)
        check(False, f"{fifo}: someone holds it open for reading")
    except OSError:
        check(True, f"{fifo}: never opened")

if failures:
    print(f"test_import_hdf5: FAIL: {len(failures)} checks failed")
    sys.exit(1)
print("test_import_hdf5: PASS")
