#!/usr/bin/python3
"""fdemrun across ranks: 48 rigid boxes thrown at each other between a bottom platen and a top one
pressing down, the same boxes elastic (4-node), and a triaxial test of 72 boxes (servo wall,
membrane, shearing), rigid and elastic, run alone and by
`mpirun -np N`, give the same results bit for bit (every dataset but the run's parameters and
provenance, and every --vtk file), and checkpoints move between rank counts: one written on N ranks
continues alone, and one written alone continues on N ranks, to the same last frame. Run by ctest
(label fdemrun) once per rank count:

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


def triaxial_text():
    """A triaxial test cut by the ranks along its height: 3 x 3 columns of 8 rigid 1 mm boxes, 2 % apart,
    consolidated in the servo wall, then in the membrane (with friction: the balls' springs must follow
    their grains' owners), sheared to 0.2 %. A soft penalty, a coarse membrane and a fast servo keep it
    to about 4 000 steps."""
    pitch = 1.02e-3
    lines = ["[run]", "damping = 2000", "frame_interval = 1e-4", "",
             "[[materials]]", 'name = "glass"', "density = 2500", "young = 60e9", "poisson = 0.2", "friction = 0.4",
             "normal_penalty = 1e12", "tangential_penalty = 1e12", ""]
    for i in (-1, 0, 1):
        for j in (-1, 0, 1):
            for k in range(8):
                lines += ["[[grains]]", "size = [1e-3, 1e-3, 1e-3]",
                          f"position = [{i * pitch!r}, {j * pitch!r}, {(k + 0.5) * pitch!r}]",
                          "element_size = 0.5e-3", 'kind = "rigid"', 'material = "glass"', ""]
    lines += ["[[platens]]", 'name = "bottom"', "point = [0, 0, 0]", "normal = [0, 0, 1]", "",
              "[[platens]]", 'name = "top"', f"point = [0, 0, {8 * pitch!r}]", "normal = [0, 0, -1]", "",
              "[sample]", f"radius = {1.5 * pitch * 2 ** 0.5 * 1.01!r}", "z_min = 0", f"z_max = {8 * pitch!r}", "",
              "[triaxial]", "ball_radius = 2.5e-4", "membrane_friction = 0.3", "servo_inertial_number = 0.1",
              "stress_tolerance = 0.02", "strain_rate = 20", "target_axial_strain = 2e-3", "shear_ramp_strain = 1e-3",
              "frame_strains = [5e-4, 1e-3]", "pressure_ramp_steps = 500", ""]
    return "\n".join(lines)


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


def same_runs(scene, tag):
    """The scene alone and on the ranks: (the alone run's results, failures)."""
    fdemrun([scene, tmp / f"{tag}_one.h5", "--vtk", tmp / f"{tag}_one_vtk"])
    fdemrun([scene, tmp / f"{tag}_many.h5", "--vtk", tmp / f"{tag}_many_vtk"], ranks)
    found = []
    vtk = sorted(p.name for p in (tmp / f"{tag}_one_vtk").iterdir())
    if vtk != sorted(p.name for p in (tmp / f"{tag}_many_vtk").iterdir()):
        found.append(f"{tag}: the --vtk folders hold different files")
    differing_vtk = [n for n in vtk if (tmp / f"{tag}_one_vtk" / n).read_bytes() != (tmp / f"{tag}_many_vtk" / n).read_bytes()]
    if differing_vtk:
        found.append(f"{tag}: --vtk files that differ from one rank's: {differing_vtk}")
    one, many = datasets(tmp / f"{tag}_one.h5"), datasets(tmp / f"{tag}_many.h5")
    if sorted(one) != sorted(many):
        found.append(f"{tag}: datasets differ: {sorted(set(one) ^ set(many))}")
    differing = [name for name in one if name in many and not same_bits(one[name], many[name])]
    if differing:
        found.append(f"{tag}: {len(differing)} datasets differ from one rank's in some bit: {differing[:8]}")
    return one, found


def across_checkpoints(scene, tag, stop):
    """Stopped at `stop` on one rank count and continued on the other, both ways: failures where the last
    frame differs from the uninterrupted run's."""
    fdemrun([scene, tmp / f"{tag}_half_many.h5", "--stop-step", stop, "--checkpoint", tmp / f"{tag}_many_ck.h5"], ranks)
    fdemrun([scene, tmp / f"{tag}_rest_one.h5", "--restart", tmp / f"{tag}_many_ck.h5"])
    fdemrun([scene, tmp / f"{tag}_half_one.h5", "--stop-step", stop, "--checkpoint", tmp / f"{tag}_alone_ck.h5"])
    fdemrun([scene, tmp / f"{tag}_rest_many.h5", "--restart", tmp / f"{tag}_alone_ck.h5"], ranks)
    reference = last_frame(tmp / f"{tag}_one.h5")
    found = []
    for name in (f"{tag}_rest_one.h5", f"{tag}_rest_many.h5"):
        got = last_frame(tmp / name)
        bad = [k for k in reference if k not in got or not same_bits(reference[k], got[k])]
        if bad:
            found.append(f"{name}'s last frame differs from the uninterrupted run's in {bad}")
    return found


def refused(cmd, code, says, tag):
    """Failures unless `cmd` exits with `code` and its stderr holds `says`."""
    r = subprocess.run([*map(str, cmd)], capture_output=True, text=True)
    if r.returncode != code or says not in r.stderr:
        return [f"{tag}: exit {r.returncode} (expected {code}), stderr {r.stderr[-600:]!r}"]
    return []


def checkpoint_parts(scene, stop):
    """A checkpoint of several ranks is its main file and one part per other rank, written by every rank
    at once; the parts' two sets take turns and the older goes; a missing part, a part as the checkpoint
    and part files in the way without --force are refused."""
    found = []
    every = scene.with_name("every_ckpt.toml")
    every.write_text(scene.read_text().replace("[run]", "[run]\ncheckpoint_interval = 2e-5", 1))
    fdemrun([every, tmp / "parts.h5", "--stop-step", stop, "--checkpoint", tmp / "parts.ckpt.h5"], ranks)
    parts = sorted(p.name for p in tmp.glob("parts.ckpt.rank*"))
    with h5py.File(tmp / "parts.ckpt.h5", "r") as f:
        named = sorted(n.decode() for n in f["part_files"][...])
        held = len(f["state/grains"])
    for name in parts:
        with h5py.File(tmp / name, "r") as f:
            held += len(f["state/grains"])
    if parts != named or len(parts) != int(ranks) - 1:
        found.append(f"the checkpoint names parts {named}, beside it are {parts}: one set of {int(ranks) - 1} expected")
    with h5py.File(tmp / "parts.h5", "r") as f:
        grains = len(f["grains/label"])
    if held != grains:
        found.append(f"the checkpoint's files hold {held} grains' rows, the model has {grains}")
    lost = tmp / parts[-1]
    lost.rename(tmp / "lost.h5")
    found += refused([bin_dir / "fdemrun", every, tmp / "x.h5", "--restart", tmp / "parts.ckpt.h5", "-q"], 2,
                     f"its part {lost} is missing", "a missing part")
    (tmp / "lost.h5").rename(lost)
    found += refused([bin_dir / "fdemrun", every, tmp / "x.h5", "--restart", lost, "-q"], 2,
                     "not a rank's part", "a part as the checkpoint")
    found += refused([*mpirun, ranks, bin_dir / "fdemrun", every, tmp / "y.h5", "--checkpoint", tmp / "parts.ckpt.h5", "-q"], 2,
                     "already exists; use --force", "a checkpoint over existing files without --force")
    if (tmp / "y.h5").exists():
        found.append("the refused run wrote its results")
    # A restart's parts are its inputs: a --checkpoint over one of them is refused before any step.
    before = lost.read_bytes()
    found += refused([bin_dir / "fdemrun", every, tmp / "z.h5", "--restart", tmp / "parts.ckpt.h5", "--checkpoint", lost,
                      "--force", "-q"], 2, "is an input", "a checkpoint over a part of the restart")
    if lost.read_bytes() != before or (tmp / "z.h5").exists():
        found.append("the refused restart touched its part or wrote results")
    return found


failures = []
with tempfile.TemporaryDirectory() as tmp:
    tmp = Path(tmp)
    scene = tmp / "scene.toml"
    scene.write_text(scene_text())
    one, found = same_runs(scene, "stages")
    failures += found
    with h5py.File(tmp / "stages_one.h5", "r") as f:
        contacts = int(np.sum(f["series/node_contacts"][...]))
        frames = len(f["frames"])
        pressed = float(np.max(np.abs(f["series/platen_force"][...])))
        half = str(int(f["series/step"][-1]) // 2)
    with h5py.File(tmp / "stages_many.h5", "r") as f:
        moved = json.loads(f["run/parameters"][0])["ranks"]
    if moved["count"] != int(ranks) or moved["migrations"] < 4 or moved["history_entries"] == 0:
        failures.append(f"the grains barely change ranks: {moved}")
    if contacts < 100 or not pressed > 0:
        failures.append(f"the boxes barely touch ({contacts} node contacts over the rows, platen force {pressed:g} N)")
    failures += across_checkpoints(scene, "stages", half)
    failures += checkpoint_parts(scene, half)

    # The same packing of elastic 4-node boxes (a softer glass): owners send surface nodes to the ranks
    # that ghost a grain and all its nodes to its next owner.
    tet4 = tmp / "tet4.toml"
    tet4.write_text(scene_text().replace('kind = "rigid"', 'kind = "tet4"').replace("young = 60e9", "young = 1e8"))
    _, found = same_runs(tet4, "tet4")
    failures += found
    with h5py.File(tmp / "tet4_one.h5", "r") as f:
        tet4_half = str(int(f["series/step"][-1]) // 2)
    failures += across_checkpoints(tet4, "tet4", tet4_half)
    with h5py.File(tmp / "tet4_many.h5", "r") as f:
        tet4_ranks = json.loads(f["run/parameters"][0])["ranks"]
    if tet4_ranks["migrations"] < 2:
        failures.append(f"the elastic boxes barely change ranks: {tet4_ranks}")

    # The triaxial test: the same series, frames and --vtk files, and checkpoints taken in the membrane
    # phase continue on the other rank count.
    triaxial = tmp / "triaxial.toml"
    triaxial.write_text(triaxial_text())
    test, found = same_runs(triaxial, "triaxial")
    failures += found
    stage = test["series/stage"]
    membrane_steps = test["series/step"][stage == 1]
    phases = [int(np.sum(stage == k)) for k in range(3)]
    if min(phases) == 0:
        failures.append(f"the triaxial test left out a phase: rows per phase {phases}")
    else:
        failures += across_checkpoints(triaxial, "triaxial", str(int(membrane_steps[len(membrane_steps) // 2])))
    with h5py.File(tmp / "triaxial_many.h5", "r") as f:
        triaxial_ranks = json.loads(f["run/parameters"][0])["ranks"]

    # The same test with the boxes elastic (4-node, a softer glass): the wall's and the membrane's
    # contacts act on nodes whose owners step their elements.
    elastic = tmp / "triaxial_tet4.toml"
    elastic.write_text(triaxial_text().replace('kind = "rigid"', 'kind = "tet4"').replace("young = 60e9", "young = 1e8"))
    elastic_test, found = same_runs(elastic, "triaxial_tet4")
    failures += found
    elastic_phases = [int(np.sum(elastic_test["series/stage"] == k)) for k in range(3)]
    if min(elastic_phases) == 0:
        failures.append(f"the elastic triaxial test left out a phase: rows per phase {elastic_phases}")

    # What runs on one rank only is refused on several, before any work, and nothing is written.
    elastostatic = tmp / "elastostatic.toml"
    elastostatic.write_text(scene_text().replace("[run]", '[run]\nrigid_stress = "elastostatic"', 1))
    cmd = [*mpirun, ranks, str(bin_dir / "fdemrun"), str(elastostatic), str(tmp / "refused.h5"), "-q"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 2 or 'rigid_stress = "elastostatic" runs on one rank so far' not in r.stderr or (tmp / "refused.h5").exists():
        failures.append(f"an elastostatic scene on {ranks} ranks: exit {r.returncode}, {r.stderr[-500:]!r}")
    implicit = tmp / "implicit.toml"
    implicit.write_text(scene_text().replace('kind = "rigid"', 'kind = "tet4"').replace("[run]", '[run]\ndeformable_integration = "implicit"', 1))
    cmd = [*mpirun, ranks, str(bin_dir / "fdemrun"), str(implicit), str(tmp / "refused.h5"), "-q"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 2 or 'deformable_integration = "implicit" with deformable grains runs on one rank so far' not in r.stderr or (tmp / "refused.h5").exists():
        failures.append(f"an implicit scene on {ranks} ranks: exit {r.returncode}, {r.stderr[-500:]!r}")

print(f"{ranks} ranks: {len(one)} datasets, {frames} frames, {contacts} node contacts over the rows, largest platen "
      f"force component {pressed:.3g} N; {moved['migrations']} migrations with {moved['history_entries']} history entries, "
      f"{moved['bytes_sent'] / 1e6:.3g} MB sent")
print(f"{ranks} ranks, tet4: {tet4_ranks['migrations']} migrations, {tet4_ranks['bytes_sent'] / 1e6:.3g} MB sent")
print(f"{ranks} ranks, triaxial: series rows per phase (wall, membrane, shearing) {phases}; {triaxial_ranks['migrations']} "
      f"migrations, {triaxial_ranks['bytes_sent'] / 1e6:.3g} MB sent, cut again {triaxial_ranks['rebalances']} times; "
      f"with 4-node boxes {elastic_phases}")
for f in failures:
    print("FAILED:", f)
sys.exit(1 if failures else 0)
