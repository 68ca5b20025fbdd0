#!/usr/bin/python3
"""Vertical (x-z) sections through the axis of every scan of a ctsynth series, each above its true
labels, with the scan's axial strain and, for a simulated series, its stress ratio.

usage: series_sections.py SERIES_DIR OUT.png

SERIES_DIR holds scan_NNN.h5 (kind=volume) and truth_NNN.h5 (kind=ground_truth), as ctsynth
writes them (docs/ctsynth.md). The section is the middle y slice of each image.
"""
import glob
import os
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    series, out = sys.argv[1], sys.argv[2]
    scans = sorted(glob.glob(os.path.join(series, "scan_[0-9][0-9][0-9].h5")))
    if not scans:
        sys.exit(f"{series}: no scan_NNN.h5; give a folder ctsynth wrote")
    fig, axes = plt.subplots(2, len(scans), figsize=(2.6 * len(scans), 5.6), squeeze=False)
    rng = np.random.default_rng(1)
    colours = None
    for k, scan_path in enumerate(scans):
        truth_path = scan_path.replace("scan_", "truth_")
        with h5py.File(scan_path, "r") as s, h5py.File(truth_path, "r") as t:
            grey = s["volume"][:, s["volume"].shape[1] // 2, :]
            labels = t["labels"][:, t["labels"].shape[1] // 2, :]
            strain = float(t.attrs["axial_strain"])
            ratio = t.attrs.get("stress_ratio")
            if colours is None:  # one colour per true grain, the same in every scan
                colours = rng.uniform(0.25, 1.0, size=(int(t["grains/label"][:].max()) + 1, 3))
                colours[0] = 0.0
        title = f"{os.path.basename(scan_path)}\naxial strain {100 * strain:.1f} %"
        if ratio is not None and np.isfinite(ratio):
            title += f"\nsigma1/sigma3 {float(ratio):.2f}"
        axes[0][k].imshow(grey, cmap="gray", origin="lower")
        axes[0][k].set_title(title, fontsize=8)
        axes[1][k].imshow(colours[labels], origin="lower")
        axes[1][k].set_title("true labels", fontsize=8)
        for a in (axes[0][k], axes[1][k]):
            a.set_xticks([])
            a.set_yticks([])
    fig.tight_layout()
    fig.savefig(out, dpi=110)


if __name__ == "__main__":
    main()
