#!/usr/bin/python3
"""Reference for ct2labels_bench: the same chain as ct2labels (docs/methods.md, segmentation) written the way
a researcher writes it with scikit-image + scipy (Debian python3-skimage 0.19, python3-scipy 1.10):
Gaussian smoothing of sigma SIGMA_VOX voxel (GrainTwin's default denoising), Otsu on the exact
integer histogram of the whole volume, hole filling, exact EDT, h-maxima markers with
the h GrainTwin chose (the same marker policy), marker watershed of -EDT inside the solid,
26-connectivity. Each step is timed; the input read and the label write are timed separately so
the benchmark can compare the segmentation with or without I/O.

usage: skimage_segment.py SCAN.h5 LABELS.mhd TIMES.json H_VOX SIGMA_VOX
  SCAN.h5     kind=volume file (/volume, uint16, attrs voxel_size (dz, dy, dx) in metres)
  LABELS.mhd  written: MetaImage header + LABELS.raw (uint32, 0 = background)
  TIMES.json  written: seconds per step, CPU seconds of the segmentation, threshold, marker count
"""
import json
import os
import sys
import time

import h5py
import numpy as np
from scipy import ndimage as ndi
from skimage.filters import threshold_otsu
from skimage.morphology import h_maxima
from skimage.segmentation import watershed


def main():
    scan, out_mhd, times_json = sys.argv[1], sys.argv[2], sys.argv[3]
    h_vox, sigma_vox = float(sys.argv[4]), float(sys.argv[5])
    times = {}
    clock = time.perf_counter

    t = clock()
    with h5py.File(scan, "r") as f:
        vol = f["volume"][...]
        spacing = np.asarray(f["volume"].attrs["voxel_size"], dtype=float)
    times["read"] = clock() - t
    cpu0 = time.process_time()  # CPU time of the segmentation: a check on contention from other work

    t = clock()
    # Edges replicated and the kernel cut at ceil(3 sigma) voxels, as GrainTwin's gaussian_smooth;
    # computed in float and rounded back to the scan's integers.
    radius = np.ceil(3.0 * sigma_vox)
    smooth = ndi.gaussian_filter(vol.astype(np.float32), sigma_vox, mode="nearest", truncate=(radius - 0.49) / sigma_vox)
    vol = np.rint(smooth).astype(vol.dtype)
    del smooth
    times["denoise"] = clock() - t

    t = clock()
    if np.issubdtype(vol.dtype, np.integer):
        # One bin per grey value, as GrainTwin does for integer scans (256 bins would move t).
        lo = int(vol.min())
        counts = np.bincount((vol.ravel() - lo).astype(np.int64))
        thr = threshold_otsu(hist=(counts, np.arange(lo, lo + counts.size)))
    else:
        thr = threshold_otsu(vol, nbins=4096)
    solid = vol > thr
    del vol
    times["threshold"] = clock() - t

    t = clock()
    solid = ndi.binary_fill_holes(solid)  # default structure: 6-connected background, as GrainTwin
    times["fill holes"] = clock() - t

    t = clock()
    unit = spacing.min()
    edt = ndi.distance_transform_edt(solid, sampling=spacing / unit)  # voxel units of the smallest side
    times["distance transform"] = clock() - t

    t = clock()
    full = np.ones((3, 3, 3), dtype=bool)  # 26-connectivity
    peaks = h_maxima(edt, h_vox, footprint=full)
    markers, n_markers = ndi.label(peaks, structure=full)
    del peaks
    times["markers"] = clock() - t

    t = clock()
    labels = watershed(-edt, markers, mask=solid, connectivity=3)
    times["watershed"] = clock() - t
    cpu = time.process_time() - cpu0
    del edt, markers, solid

    t = clock()
    raw = os.path.splitext(out_mhd)[0] + ".raw"
    labels.astype("<u4", copy=False).tofile(raw)
    nz, ny, nx = labels.shape
    dz, dy, dx = spacing * 1e3  # MetaImage spacing in millimetres (ITK convention)
    with open(out_mhd, "w") as f:
        f.write(
            "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
            f"DimSize = {nx} {ny} {nz}\nElementSpacing = {dx} {dy} {dz}\nElementType = MET_UINT\n"
            f"ElementDataFile = {os.path.basename(raw)}\n"
        )
    times["write"] = clock() - t

    with open(times_json, "w") as f:
        json.dump({"steps": times, "cpu": cpu, "threshold": float(thr), "markers": int(n_markers),
                   "labels": int(labels.max())}, f)


if __name__ == "__main__":
    main()
