# SPDX-License-Identifier: Apache-2.0
"""Writes fuzz_hdf5's seed corpus (tests/fuzz/corpus/hdf5): tiny HDF5 files, each a few KB,
one per way nebimport meets a dataset. Run it again (python3 make_hdf5_corpus.py) after
changing it; the files are committed.

    plain        a 4x4x4 float32 cube, contiguous, with units, voxel_size_pc and origin_pc
    gzip         6x5x4 float32, chunked 2x5x4 with shuffle, gzip and fletcher32, one chunk
                 never written (the fill value)
    int16-be     big-endian int16, chunked, fixed-length (NULLPAD) units on the root group
    external     values in another file (external storage naming /etc/passwd): refused
    virtual      a virtual dataset mapped from src.h5: refused
    links        a soft link and an external link beside a real cube
    lzf          LZF-compressed (h5py's filter 32000): refused where libhdf5 lacks it
    unwritten    a declared 64x64x64 dataset with no stored values: refused
"""
import os
import sys

import h5py
import numpy as np

out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus", "hdf5")
os.makedirs(out, exist_ok=True)
os.chdir(out)
cube = np.arange(64, dtype="<f4").reshape(4, 4, 4) / 8

with h5py.File("plain", "w") as f:
    d = f.create_dataset("density", data=cube)
    d.attrs["units"] = "cm-3"
    d.attrs["voxel_size_pc"] = 0.5
    d.attrs["origin_pc"] = [1.0, -2.0, 0.25]

with h5py.File("gzip", "w", libver="latest") as f:
    d = f.create_dataset("sim/rho", shape=(6, 5, 4), dtype="<f4", chunks=(2, 5, 4),
                         compression="gzip", shuffle=True, fletcher32=True, fillvalue=0.5)
    d[0:4] = np.linspace(0, 1, 80, dtype="<f4").reshape(4, 5, 4)
    d.attrs["units"] = "g/cm3"

with h5py.File("int16-be", "w", libver="latest") as f:
    f.create_dataset("n", data=(np.arange(48) % 7).astype(">i2").reshape(3, 4, 4),
                     chunks=(1, 4, 4))
    f.attrs["units"] = np.bytes_("cm-3")
    f.attrs["voxel_size_pc"] = [0.1, 0.1, 0.1]

with h5py.File("external", "w") as f:
    f.create_dataset("density", shape=(4, 4, 4), dtype="u1", external=[("/etc/passwd", 0, 64)])

layout = h5py.VirtualLayout(shape=(4, 4, 4), dtype="<f4")
layout[:] = h5py.VirtualSource("src.h5", "density", shape=(4, 4, 4))
with h5py.File("virtual", "w") as f:
    f.create_virtual_dataset("density", layout, fillvalue=0)

with h5py.File("links", "w") as f:
    f.create_dataset("real", data=cube)
    f["soft"] = h5py.SoftLink("/real")
    f["other"] = h5py.ExternalLink("other.h5", "/density")

with h5py.File("lzf", "w") as f:
    f.create_dataset("density", data=cube, compression="lzf")

with h5py.File("unwritten", "w") as f:
    f.create_dataset("density", shape=(64, 64, 64), dtype="<f4")

for name in sorted(os.listdir(".")):
    size = os.path.getsize(name)
    print(f"{name}: {size} bytes")
    if size > 8192:
        sys.exit(f"{name} is larger than 8 KiB")
