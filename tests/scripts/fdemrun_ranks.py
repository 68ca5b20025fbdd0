#!/usr/bin/python3
"""fdemrun across ranks: 48 rigid boxes thrown at each other between a bottom platen and a top one
pressing down, run alone and by `mpirun -np N`, give the same results bit for bit (every dataset but
the run's parameters and provenance, and every --vtk file), and checkpoints move between rank counts: one written on N
ranks continues alone, and one written alone continues on N ranks, to the same last frame. Run by
ctest (label fdemrun) once per rank count:

    fdemrun_ranks.py BIN_DIR RANKS MPIRUN [MPIRUN ARGS...]   (MPIRUN ARGS end with the -np flag)
"""
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

bin_dir, ranks, mpirun = Path(sys.argv[1]), sys.argv[2], sys.argv[3:]


def scene_text():
    lines = ["[run]", "gravity = [0, 0, -9.81]", "frame_interval = 1e-4", "series_interval = 1e-5", "",
             "[[materials]]", 'name = "glass"', "density = 2500", "young = 60e9", "poisson = 0.2", "friction = 0.4", ""]
    # 6 x 4 x 2 boxes 1.2 mm apart (each of 4 ranks' boxes is wider than a box's diagonal); neighbours
    # along x thrown towards each other, all spun.
    i = 0
    for k in range(2):
        for j in range(4):
            for x in range(6):
                vx = 6.0 + (3.0 if (x + j + k) % 2 == 0 else -3.0)  # a common drift carries them across the ranks
                lines += ["[[grains]]", "size = [1e-3, 1e-3, 1e-3]", f"position = [{1.2e-3 * x!r}, {1.2e-3 * j!r}, {1.2e-3 * k!r}]",
                          "element_size = 0.5e-3", 'kind = "rigid"', 'material = "glass"',
                          f"velocity = [{vx}, {0.5 * ((i * 7) % 3 - 1)}, {0.8 * ((i * 5) % 3 - 1)}]",
                          f"angular_velocity = [{1e3 * ((i * 3) % 5 - 2)}, {1e3 * ((i * 2) % 3 - 1)}, {1e3 * (i % 3 - 1)}]", ""]
                i += 1
    lines += ["[[platens]]", 'name = "bottom"', "point = [0, 0, -0.55e-3]", "normal = [0, 0, 1]", "friction = 0.3", "",
              "[[platens]]", 'name = "top"', "point = [0, 0, 1.8e-3]", "normal = [0, 0, -1]", "friction = 0.3", "",
              "[[stages]]", 'name = "churn"', "duration = 2e-4", "",
              "[[stages]]", 'name = "press"', "duration = 2e-4", "platens = { top = [0, 0, -2] }", ""]
    return "\n".join(lines)


TRIAXIAL = """[sample]
radius = 5e-3
axis_xy = [3e-3, 2e-3, 0]
z_min = -0.6e-3
z_max = 1.8e-3

[triaxial]
boundary = "wall"
confining_pressure = 1e5
target_axial_strain = 0.01
"""


def fdemrun(args, on_ranks=None):
    cmd = [str(bin_dir / "fdemrun"), *map(str, args), "-q", "-j", "1", "--force"]
    if on_ranks:
        cmd = [*mpirun, on_ranks, *cmd]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed ({r.returncode}):\n{r.stderr[-3000:]}")


def datasets(path):
    """Every dataset's array but the run's parameters and provenance, by name."""
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, item):
            if isinstance(item, h5py.Dataset) and "provenance" not in name and "parameters" not in name:
                out[name] = item[...]
        f.visititems(visit)
    return out


def same_bits(a, b):
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype.kind in "OSU":  # strings: h5py's object arrays hold references, not the bytes
        return a.shape == b.shape and a.tolist() == b.tolist()
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def last_frame(path):
    """The last frame's datasets (grains, contacts) by name."""
    out = {}
    with h5py.File(path, "r") as f:
        frame = f["frames"][sorted(f["frames"].keys())[-1]]
        frame.visititems(lambda name, item: out.__setitem__(name, item[...]) if isinstance(item, h5py.Dataset) else None)
    return out


failures = []
with tempfile.TemporaryDirectory() as tmp:
    tmp = Path(tmp)
    scene = tmp / "scene.toml"
    scene.write_text(scene_text())
    fdemrun([scene, tmp / "one.h5", "--vtk", tmp / "one_vtk"])
    fdemrun([scene, tmp / "many.h5", "--vtk", tmp / "many_vtk"], ranks)
    vtk = sorted(p.name for p in (tmp / "one_vtk").iterdir())
    if vtk != sorted(p.name for p in (tmp / "many_vtk").iterdir()):
        failures.append("the --vtk folders hold different files")
    differing_vtk = [n for n in vtk if (tmp / "one_vtk" / n).read_bytes() != (tmp / "many_vtk" / n).read_bytes()]
    if differing_vtk:
        failures.append(f"--vtk files that differ from one rank's: {differing_vtk}")
    one, many = datasets(tmp / "one.h5"), datasets(tmp / "many.h5")
    if sorted(one) != sorted(many):
        failures.append(f"datasets differ: {sorted(set(one) ^ set(many))}")
    differing = [name for name in one if name in many and not same_bits(one[name], many[name])]
    if differing:
        failures.append(f"{len(differing)} datasets differ from one rank's in some bit: {differing[:8]}")
    with h5py.File(tmp / "one.h5", "r") as f:
        contacts = int(np.sum(f["series/node_contacts"][...]))
        frames = len(f["frames"])
        pressed = float(np.max(np.abs(f["series/platen_force"][...])))
        half = str(int(f["series/step"][-1]) // 2)
    with h5py.File(tmp / "many.h5", "r") as f:
        moved = json.loads(f["run/parameters"][0])["ranks"]
    if moved["count"] != int(ranks) or moved["migrations"] < 4 or moved["history_entries"] == 0:
        failures.append(f"the grains barely change ranks: {moved}")
    if contacts < 100 or not pressed > 0:
        failures.append(f"the boxes barely touch ({contacts} node contacts over the rows, platen force {pressed:g} N)")

    # Checkpoints across rank counts: stopped half way on one count, continued on the other.
    fdemrun([scene, tmp / "half_many.h5", "--stop-step", half, "--checkpoint", tmp / "many_ck.h5"], ranks)
    fdemrun([scene, tmp / "rest_one.h5", "--restart", tmp / "many_ck.h5"])
    fdemrun([scene, tmp / "half_one.h5", "--stop-step", half, "--checkpoint", tmp / "alone_ck.h5"])
    fdemrun([scene, tmp / "rest_many.h5", "--restart", tmp / "alone_ck.h5"], ranks)
    reference = last_frame(tmp / "one.h5")
    for name in ("rest_one.h5", "rest_many.h5"):
        got = last_frame(tmp / name)
        bad = [k for k in reference if k not in got or not same_bits(reference[k], got[k])]
        if bad:
            failures.append(f"{name}'s last frame differs from the uninterrupted run's in {bad}")

    # What runs on one rank only is refused on several, before any work, and nothing is written.
    triaxial = tmp / "triaxial.toml"
    triaxial.write_text(scene_text().split("[[platens]]")[0] + TRIAXIAL)
    cmd = [*mpirun, ranks, str(bin_dir / "fdemrun"), str(triaxial), str(tmp / "refused.h5"), "-q"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 2 or "a [triaxial] test runs on one rank so far" not in r.stderr or (tmp / "refused.h5").exists():
        failures.append(f"a triaxial scene on {ranks} ranks: exit {r.returncode}, {r.stderr[-500:]!r}")

print(f"{ranks} ranks: {len(one)} datasets, {frames} frames, {contacts} node contacts over the rows, largest platen "
      f"force component {pressed:.3g} N; {moved['migrations']} migrations with {moved['history_entries']} history entries, "
      f"{moved['bytes_sent'] / 1e6:.3g} MB sent")
for f in failures:
    print("FAILED:", f)
sys.exit(1 if failures else 0)
