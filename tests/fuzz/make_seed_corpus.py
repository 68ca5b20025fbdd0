#!/usr/bin/env python3
"""Writes the seed corpus of the fuzz targets, tests/fuzz/corpus/<target>/ (docs/testing.md).

Byte-level targets get small valid files of their format (TIFF stacks written with the project's
own volconvert when a build is given, PNG and MetaImage made here, the bundled fdemrun scenes);
the structure-aware HDF5 targets get short edit programs (h5_mutator.cpp: op, object, parameter).
    python3 tests/fuzz/make_seed_corpus.py [BIN_DIR]     (default build/bin)
"""
import json
import pathlib
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib

ROOT = pathlib.Path(__file__).resolve().parents[2]
CORPUS = ROOT / "tests" / "fuzz" / "corpus"
H5_TARGETS = ["volume", "labels", "contacts", "shapes", "tracks", "micro", "forces", "model", "results",
              "checkpoint", "ground_truth", "history"]


def put(target, name, data):
    d = CORPUS / target
    d.mkdir(parents=True, exist_ok=True)
    (d / name).write_bytes(data if isinstance(data, bytes) else data.encode())


def png(width, height, depth, pixels):
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)
    rows = b"".join(b"\0" + pixels[y * width * depth // 8:(y + 1) * width * depth // 8] for y in range(height))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, depth, 0, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


def validation_seed():
    """A small validation.json as validate writes it (validate/validation_file.cpp)."""
    seg = {"name": "scan_000", "true_grains": 3, "right": 2, "split": 0, "merged": 1, "missed": 0, "boundary": 0, "labels": 2,
           "spurious": 0, "right_share": 0.67, "void_ratio": 0.7, "void_ratio_true": None}
    con = {"name": "scan_000", "present": True, "true_touching": 2, "found": 1, "missed": 1, "false": 0, "found_share": 0.5,
           "normal_error_median_deg": 4.0, "normal_error_p90_deg": 4.0, "anisotropy": 0.1, "anisotropy_true": 0.2,
           "normal_error_deg": [4.0]}
    sha = {"name": "scan_000", "present": True, "grains": 2, "invariant_error_by_degree": [0.01, None, 0.1],
           "invariant_error_median": 0.1, "volume_error_median": -0.01, "diameter_error_median": -0.003, "volume_error": [-0.01, 0.0]}
    trk = {"from": 0, "to": 1, "targets": 2, "right": 1, "wrong": 1, "lost": 0, "displacement_error_median_m": 1e-6,
           "displacement_error_p90_m": 1e-6, "displacement_error_rel_median": 0.1, "rotation_error_median_deg": None,
           "rotation_error_p90_deg": None, "displacement_error_m": [1e-6], "rotation_error_deg": []}
    d2 = {"from": 0, "to": 1, "grains": 2, "d2min_spearman": None, "eps_q_spearman": None, "cluster_members": 1,
          "cluster_members_true": 1, "cluster_common": 1, "cluster_jaccard": 1.0, "d2min": [0.1, 0.2], "d2min_true": [0.1, 0.3]}
    twin = {"simulated": True, "simulation": True, "stress_ratio_rms_rel": 0.1, "volumetric_strain_max_abs": 0.001,
            "axial_strain_max": 0.01, "axial_strain": [0.0, 0.01], "stress_ratio_true": [1.0, 2.0], "stress_ratio": [1.0, 2.2],
            "volumetric_strain_true": [0.0, 0.0], "volumetric_strain": [0.0, 0.001]}
    return {"kind": "validation", "schema_version": 1, "run": "runs/x", "series": "sample_volumes/x",
            "segmentation": {"grains_right": 0.67, "void_ratio_error_max_abs": None, "scans": [seg, dict(seg, name="scan_001")]},
            "contacts": {"found_share": 0.5, "false": 0, "normal_error_median_deg": 4.0, "anisotropy_error_max_abs": 0.1,
                         "scans": [con, {"name": "scan_001", "present": False}]},
            "shapes": {"invariant_error_median": 0.1, "volume_error_median": -0.01, "scans": [sha, dict(sha, name="scan_001")]},
            "tracking": {"right": 1, "wrong": 1, "lost": 0, "displacement_error_median_m": 1e-6,
                         "displacement_error_rel_median": 0.1, "rotation_error_median_deg": None, "increments": [trk]},
            "d2min": {"spearman": None, "increments": [d2]}, "eps_q": {"spearman": None}, "clusters": {"jaccard": 1.0},
            "twin": twin, "history": ["ctsynth ...", "validate ..."]}


def main():
    bin_dir = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else ROOT / "build" / "bin")
    shutil.rmtree(CORPUS, ignore_errors=True)
    # Edit programs: each op on a spread of objects, one and two edits.
    for t in H5_TARGETS:
        for op in range(7):
            for obj in (3, 12):
                put(t, f"op{op}_obj{obj}", bytes([op, obj, 0]) + struct.pack("<Q", 0x0123456789ABCDEF * (obj + 1) & (2**64 - 1)))
        put(t, "two_edits", bytes([2, 5, 0]) + struct.pack("<Q", 6) + bytes([4, 9, 0]) + struct.pack("<Q", 3 << 24))
    # PNG slices: 8 and 16 bit grey, and a 1-bit one that is expanded.
    put("png", "grey8.png", png(5, 4, 8, bytes(range(20))))
    put("png", "grey16.png", png(3, 2, 16, bytes(range(12))))
    put("png", "grey1.png", png(8, 2, 1, b"\xa5\x5a"))
    # MetaImage: inline data (.mha) and a header naming data.raw (64 bytes beside it in the target).
    put("metaimage", "local.mha", b"ObjectType = Image\nNDims = 3\nDimSize = 2 3 2\nElementSpacing = 0.1 0.1 0.2\n"
        b"Offset = 1 2 3\nElementType = MET_USHORT\nBinaryDataByteOrderMSB = False\nElementDataFile = LOCAL\n" + bytes(24))
    put("metaimage", "raw_file.mhd", "NDims = 3\nDimSize = 4 4 4\nElementType = MET_UCHAR\nHeaderSize = 0\n"
        "ElementDataFile = data.raw\n")
    put("metaimage", "float_big_endian.mha", b"NDims = 3\nDimSize = 1 1 2\nElementType = MET_FLOAT\n"
        b"ElementByteOrderMSB = True\nElementDataFile = LOCAL\n" + struct.pack(">ff", 1.5, -2.0))
    # Raw: layout bytes (3 dims, flags, header size) then the file.
    put("raw", "u8_2x2x2", bytes([2, 2, 2, 0, 0]) + bytes(range(8)))
    put("raw", "u16_be_header", bytes([1, 2, 3, 1 | 4, 4]) + bytes(4) + bytes(range(12)))
    put("raw", "f32_1x1x2", bytes([1, 1, 2, 3, 0]) + struct.pack("<ff", 0.5, 7.0))
    # Scenes: the bundled ones and one that takes the model file beside it.
    for s in sorted((ROOT / "pipelines" / "scenes").glob("*.toml")):
        put("scene", s.name, s.read_bytes())
    put("scene", "model_file.toml", '[run]\ngravity = [0, 0, -9.81]\n\n[model]\nfile = "model.h5"\nkind = "rigid"\n\n'
        '[[platens]]\nname = "bottom"\npoint = [0, 0, -1e-3]\nnormal = [0, 0, 1]\n\n[[stages]]\nname = "s"\nduration = 1e-6\n')
    # validation.json: a two-scan budget with every line, and one with nulls and no scans.
    put("validation", "two_scans.json", json.dumps(validation_seed()))
    empty = validation_seed()
    for section in ("segmentation", "contacts", "shapes"):
        empty[section]["scans"] = []
    empty["tracking"]["increments"], empty["d2min"]["increments"] = [], []
    put("validation", "no_scans.json", json.dumps(empty))
    # TIFF stacks from the project's writer: uint16, uint8 and float32 crops of the base volume.
    volconvert = bin_dir / "volconvert"
    if volconvert.exists():
        with tempfile.TemporaryDirectory() as tmp:
            base = ROOT / "tests" / "fuzz" / "base" / "volume.h5"
            for name, extra in (("u16", []), ("u8", ["--cast", "uint8"]), ("f32", ["--cast", "float32"])):
                out = pathlib.Path(tmp) / f"{name}.tif"
                subprocess.run([str(volconvert), str(base), str(out), "--crop", "0:3,0:6,0:5", "-q"] + extra, check=True)
                put("tiff", f"{name}.tif", out.read_bytes())
    else:
        print(f"no {volconvert}: TIFF seeds not written", file=sys.stderr)


if __name__ == "__main__":
    main()
