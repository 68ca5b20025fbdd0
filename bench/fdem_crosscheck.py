#!/usr/bin/python3
"""fdemrun against an independent code: the Chung & Ooi (2011) sphere impacts (tests 1, 2, 6, 7) in
LIGGGHTS 3.8 (Debian's `liggghts`, Hertz normal force with Mindlin tangential history, rigid
spheres) and in GrainTwin (fdemrun_verify_bench --part chung-ooi: elastic spheres meshed fine at the
contact, node-to-surface penalty contact), side by side with the analytic answers. Prints the
table and rewrites the `fdem_crosscheck` section of docs/benchmarks.md.

LIGGGHTS' wall has the particle's material, so a rigid wall is modelled by doubling E (the same
E* = E / (1 - nu^2) as a rigid plane; LIGGGHTS-PFM's Chung & Ooi test inputs do the same). Restitution 1
(no damping) on both sides, so the runs are elastic like ours.

usage: bench/fdem_crosscheck.py [--build DIR] [--work DIR] [--reuse]
  --build DIR  the CMake build folder holding bin/fdemrun_verify_bench (default: build)
  --work DIR   scratch folder (default: bench/out/fdem_crosscheck)
  --reuse      take GrainTwin's figures from WORK/chung_ooi.csv of an earlier run instead of running it
Installs: bench/deps-bench.sh (liggghts from Debian)."""
import argparse
import csv
import math
import os
import shutil
import subprocess
import sys
import time
from datetime import date

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_doc import cpu_model, publish  # noqa: E402

SOURCE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

GLASS = dict(E=48e9, nu=0.2, rho=2800.0)
ALUMINIUM = dict(E=70e9, nu=0.33, rho=2699.0)

# name: (material, radius m, speed m/s (each body), spin about y rad/s, two spheres, friction)
CASES = {
    "test1_glass": (GLASS, 10e-3, 10.0, 0.0, True, 0.0),
    "test2_al_alloy": (ALUMINIUM, 0.1, 0.2, 0.0, False, 0.0),
    "test6_spin_1": (ALUMINIUM, 0.1, 0.2, 1.0, False, 0.4),
    "test6_spin_4": (ALUMINIUM, 0.1, 0.2, 4.0, False, 0.4),
    "test6_spin_8": (ALUMINIUM, 0.1, 0.2, 8.0, False, 0.4),
    "test6_spin_14": (ALUMINIUM, 0.1, 0.2, 14.0, False, 0.4),
    "test6_spin_21": (ALUMINIUM, 0.1, 0.2, 21.0, False, 0.4),
    "test7_spin_4": (ALUMINIUM, 0.1, 0.2, 4.0, True, 0.4),
    "test7_spin_21": (ALUMINIUM, 0.1, 0.2, 21.0, True, 0.4),
}


def liggghts_input(material, radius, speed, spin, two_spheres, friction, dt, steps, dump_every):
    """A LIGGGHTS input: the upper sphere above z = 0 moving down with spin about y; a lower mirror
    sphere with opposite spin (test 7) or the wall z = 0."""
    E = material["E"] * (1 if two_spheres else 2)
    gap = 1e-6 * radius
    box = 3 * radius
    lines = [
        "atom_style granular", "atom_modify map array", "boundary f f f", "newton off",
        "communicate single vel yes", "units si", "hard_particles yes",
        f"region box block {-box} {box} {-box} {box} {-box} {box} units box",
        "create_box 1 box", f"neighbor {0.1 * radius} bin", "neigh_modify delay 0",
        f"fix m1 all property/global youngsModulus peratomtype {E}",
        f"fix m2 all property/global poissonsRatio peratomtype {material['nu']}",
        "fix m3 all property/global coefficientRestitution peratomtypepair 1 1.0",
        f"fix m4 all property/global coefficientFriction peratomtypepair 1 {friction}",
        "pair_style gran model hertz tangential history", "pair_coeff * *",
        f"timestep {dt}",
        f"create_atoms 1 single 0 0 {radius + gap} units box",
    ]
    if two_spheres:
        lines.append(f"create_atoms 1 single 0 0 {-(radius + gap)} units box")
    else:
        lines.append("fix wall all wall/gran model hertz tangential history primitive type 1 zplane 0.0")
    lines += [
        f"set atom 1 diameter {2 * radius} density {material['rho']}",
        f"velocity all set 0 0 0 units box",
        f"set atom 1 vx 0 vy 0 vz {-speed} omegax 0 omegay {spin} omegaz 0",
    ]
    if two_spheres:
        lines += [f"set atom 2 diameter {2 * radius} density {material['rho']}",
                  f"set atom 2 vx 0 vy 0 vz {speed} omegax 0 omegay {-spin} omegaz 0"]
    lines += [
        "fix integrate all nve/sphere",
        f"dump d all custom {dump_every} traj.dump id z vx vz fz omegay",
        "dump_modify d sort id",
        "thermo 100000",
        f"run {steps}",
    ]
    return "\n".join(lines) + "\n"


def hertz(material, radius, speed, two_spheres):
    n = 2 if two_spheres else 1
    mass = material["rho"] * 4 / 3 * math.pi * radius**3
    m, r, e_star, v = mass / n, radius / n, material["E"] / (1 - material["nu"]**2) / n, n * speed
    delta = (15 * m * v * v / (16 * e_star * math.sqrt(r)))**0.4
    return delta, 4 / 3 * e_star * math.sqrt(r) * delta**1.5, 2.868 * (m * m / (r * e_star * e_star * v))**0.2


def run_liggghts(name, case, work):
    material, radius, speed, spin, two_spheres, friction = case
    _, _, t_c = hertz(material, radius, speed, two_spheres)
    dt = t_c / 2000  # 2000 steps per contact (Yade's Chung & Ooi scripts are finer than the Rayleigh step)
    steps = 2600
    folder = os.path.join(work, "liggghts_" + name)
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, "in.impact"), "w") as f:
        f.write(liggghts_input(material, radius, speed, spin, two_spheres, friction, dt, steps, 1))
    t0 = time.monotonic()
    with open(os.path.join(folder, "log.txt"), "w") as log:
        subprocess.run(["liggghts", "-in", "in.impact", "-echo", "none", "-screen", "none"], cwd=folder, stdout=log,
                       stderr=subprocess.STDOUT, check=True)
    seconds = time.monotonic() - t0
    # dump: per frame "ITEM: TIMESTEP", step, ..., "ITEM: ATOMS id z vx vz fz omegay", one row per atom
    frames, rows = [], None
    with open(os.path.join(folder, "traj.dump")) as f:
        for line in f:
            if line.startswith("ITEM: ATOMS"):
                rows = []
                frames.append(rows)
            elif line.startswith("ITEM:"):
                rows = None
            elif rows is not None:
                rows.append([float(x) for x in line.split()])
    touching = 2 * radius if two_spheres else radius
    overlap, force, in_contact = 0.0, 0.0, 0
    for rows in frames:
        upper = rows[0]
        distance = upper[1] - rows[1][1] if two_spheres else upper[1]
        o = touching - distance
        overlap = max(overlap, o)
        if o > 0:
            in_contact += 1
            force = max(force, abs(upper[4]))
    last = frames[-1][0]
    vx, vz, omega = last[2], last[3], last[5]
    return dict(max_overlap_um=1e6 * overlap, peak_force_N=force, contact_time_us=1e6 * in_contact * dt,
                restitution=vz / speed, seconds=seconds, vx=vx, vz=vz, omega=omega, spin=spin, radius=radius,
                friction=friction, speed=speed)


def read_ours(path):
    ours = {}
    with open(path) as f:
        for row in csv.DictReader(f):
            ours.setdefault(row["case"], {})[row["quantity"]] = (float(row["graintwin"]),
                                                                 float(row["reference"]) if row["reference"] else None)
    return ours


def table(ours, theirs):
    out = ["| case | quantity | exact (Hertz / sliding solution) | GrainTwin | LIGGGHTS 3.8 | GrainTwin / LIGGGHTS |",
           "|---|---|---|---|---|---|"]
    times = []
    for name, lig in theirs.items():
        mine = ours.get(name, {})
        if name.startswith("test1") or name.startswith("test2"):
            quantities = ["max_overlap_um", "peak_force_N", "contact_time_us", "restitution"]
            values = {q: lig[q] for q in quantities}
        else:
            r = lig["radius"]
            v_ct = lig["spin"] * r
            if name.startswith("test6"):
                v_ct_after = -(lig["vx"] - lig["omega"] * r)
                values = {"beta": -v_ct_after / v_ct, "spin_after_rad_s": lig["omega"], "restitution": lig["restitution"]}
            else:
                values = {"tangential_velocity_after_m_s": lig["vx"], "spin_after_rad_s": lig["omega"]}
            quantities = list(values)
        for q in quantities:
            g, exact = mine.get(q, (None, None))
            ratio = f"{g / values[q]:.4f}" if g is not None and values[q] != 0 else "-"
            out.append(f"| {name} | {q} | {'' if exact is None else f'{exact:.4g}'} | "
                       f"{'not run' if g is None else f'{g:.4g}'} | {values[q]:.4g} | {ratio} |")
        g_seconds = mine.get("seconds", (None, None))[0]
        times.append(f"{name}: GrainTwin {'-' if g_seconds is None else f'{g_seconds:.1f}'} s, LIGGGHTS {lig['seconds']:.2f} s")
    return "\n".join(out), times


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--build", default=os.path.join(SOURCE, "build"))
    p.add_argument("--work", default=os.path.join(SOURCE, "bench", "out", "fdem_crosscheck"))
    p.add_argument("--reuse", action="store_true")
    a = p.parse_args()
    if shutil.which("liggghts") is None:
        sys.exit("fdem_crosscheck: liggghts is not installed; run bench/deps-bench.sh (Debian package liggghts)")
    os.makedirs(a.work, exist_ok=True)
    ours_csv = os.path.join(a.work, "chung_ooi.csv")
    if not a.reuse:
        bench = os.path.join(a.build, "bin", "fdemrun_verify_bench")
        if not os.path.exists(bench):
            sys.exit(f"fdem_crosscheck: {bench} is missing; build it (ninja -C {a.build} fdemrun_verify_bench) or pass --build")
        subprocess.run([bench, "--part", "chung-ooi", "--work", a.work], check=True)
    elif not os.path.exists(ours_csv):
        sys.exit(f"fdem_crosscheck: --reuse needs {ours_csv} from an earlier run; run without --reuse")
    theirs = {name: run_liggghts(name, case, a.work) for name, case in CASES.items()}
    text_table, times = table(read_ours(ours_csv), theirs)
    cpu = cpu_model()
    text = ("## fdemrun against LIGGGHTS: Chung & Ooi (2011) sphere impacts\n\n"
            "Tests 1 (two glass spheres R = 10 mm at +-10 m/s), 2 (Al-alloy sphere R = 0.1 m at 0.2 m/s on a rigid wall), "
            "6 (the same with spin about y, mu = 0.4) and 7 (two such spheres spinning so their contact points move "
            "together). GrainTwin (fdemrun_verify_bench --part chung-ooi): elastic spheres meshed fine at the contact, "
            "10-node elements of the Hertz contact radius a growing by 0.15 (tests 1, 2; the 4-node row of test 1 is in "
            "fdemrun_verify_bench_chung_ooi) and 4-node ones of a/2 growing by 0.15 (tests 6, 7), p_n = p_t = 10 E/h, no "
            "damping. LIGGGHTS 3.8.0 (Debian): rigid spheres, Hertz normal "
            "force with Mindlin tangential history, restitution 1, 2000 steps per Hertz contact time, rigid wall as E x 2. "
            "beta = -v'_ct / v_ct of the contact point; restitution = rebound / impact normal speed. Overlap: approach "
            "of the centres since touching.\n\n"
            f"Measured on {cpu}, {os.cpu_count()} cores, {date.today()} by `bench/fdem_crosscheck.py`.\n\n"
            + text_table + "\n\nRun times (one thread each): " + "; ".join(times) + ".\n")
    print(text)
    publish("fdem_crosscheck", text)


if __name__ == "__main__":
    main()
