#!/usr/bin/python3
"""volconvert interoperability: h5py reads our .h5 back byte-identical to the source raw file, and
sees every attribute the format promises (docs/formats.md). Run by ctest (label volconvert)."""
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

bin_dir, source_dir = Path(sys.argv[1]), Path(sys.argv[2])
crop = source_dir.parent / "shared" / "real_data" / "emsl_soil_core_xct"
raw = np.fromfile(crop / "bean_bucket_soil_crop_100x256x256_u8.raw", dtype=np.uint8).reshape(100, 256, 256)

with tempfile.TemporaryDirectory() as tmp:
    out = Path(tmp) / "soil.h5"
    subprocess.run([bin_dir / "volconvert", crop / "bean_bucket_soil_crop_100x256x256_u8.mhd", out, "-q"], check=True)
    with h5py.File(out, "r") as f:
        assert f.attrs["kind"] == "volume", f.attrs["kind"]
        assert int(f.attrs["schema_version"]) == 1
        vol = f["volume"]
        assert vol.dtype == np.uint8 and vol.shape == (100, 256, 256), (vol.dtype, vol.shape)
        assert np.array_equal(vol[...], raw), "voxels differ from the raw file"
        assert vol.attrs["axis_order"] == "zyx"
        assert np.allclose(vol.attrs["voxel_size"], [60.7e-6] * 3, rtol=1e-12)
        assert vol.compression == "gzip" and vol.chunks is not None
        history = [h.decode() if isinstance(h, bytes) else h for h in f["provenance/history"][...]]
        assert len(history) == 1 and history[0].startswith("volconvert "), history
print("1 passed, 0 failed")
