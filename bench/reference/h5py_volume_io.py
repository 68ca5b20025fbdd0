#!/usr/bin/python3
"""Reference for volume_io_bench: the same gzip+shuffle chunked write / full read with h5py (Debian)."""
import sys

import h5py
import numpy as np

mode, path = sys.argv[1], sys.argv[2]
if mode == "write":
    n = int(sys.argv[3])
    rng = np.random.default_rng(1)
    vol = (20000 + 3000 * rng.standard_normal((n, n, n))).astype(np.uint16)
    with h5py.File(path, "w") as f:
        f.create_dataset("volume", data=vol, chunks=(16, 64, min(n, 256)), shuffle=True, compression="gzip",
                         compression_opts=4)
else:
    with h5py.File(path, "r") as f:
        vol = f["volume"][...]
    print(int(vol.max()))
