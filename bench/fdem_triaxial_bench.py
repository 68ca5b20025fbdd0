#!/usr/bin/python3
"""fdemrun's triaxial test on the FDEM twin of the bundled sample (runs/sand_small/model.h5, the
pipeline's mesh stage): 310 rigid grains, consolidation to 300 kPa in the servo wall, the membrane's
forming procedure, shearing to 6 % axial strain.

Part `fidelity`: the shearing rate, as an inertial number I (1e-3 is quasi-static and the reference;
3e-3, 1e-2, 3e-2), against what it costs: the RMS difference of sigma_1 / sigma_3 and of eps_v from
the reference over eps_1 in [0, 6 %], against the run's CPU time; chart
docs/img/fdem_triaxial_fidelity.png. Part `boundary`: the latex membrane 0.3 / 0.6 / 1.0 mm thick and
the rigid servo wall, at the pipeline's rate: stress ratio and volumetric strain against axial
strain and the deformed shape (the membrane's inner radius against height at the end); chart
docs/img/fdem_triaxial_boundary.png. (Rigid against deformable grains: bench/fdem_fidelity_bench.py.)
Prints the tables and rewrites the `fdem_triaxial` section of docs/benchmarks.md.

usage: bench/fdem_triaxial_bench.py [--build DIR] [--model FILE] [--work DIR] [--part all|fidelity|boundary]
                                    [--jobs N] [--reuse]
  --build DIR  CMake build folder holding bin/fdemrun (default: build)
  --model FILE the kind=fdem_model to test (default: runs/sand_small/model.h5; make -f Makefile.pipeline mesh)
  --work DIR   scratch folder for scenes, results and logs (default: bench/out/fdem_triaxial)
  --jobs N     runs side by side, one thread each (default 1: CPU times are then comparable)
  --reuse      keep results already in WORK (e.g. after an interrupted bench) instead of running them again
  --publish-only  run nothing: tables and charts of the results already in WORK"""
import argparse
import json
import math
import os
import subprocess
import sys
import time
from datetime import date

import h5py
import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_doc import cpu_model, publish_runs  # noqa: E402

SOURCE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TARGET = 0.06
PIPELINE_RATE = "1e-2"  # pipelines/scenes/triaxial.toml
REFERENCE = "rate_1e-3"
REPLICATE = "replicate_1e-2_2threads"



def scene(shear_inertial_number, boundary="membrane", thickness=None):
    """The pipeline's scene (pipelines/scenes/triaxial.toml) with the knobs of one run."""
    lines = ["[run]", "damping = 2000", "[model]", 'kind = "rigid"',
             "[triaxial]", f'boundary = "{boundary}"',
             "servo_inertial_number = 1e-2", f"shear_inertial_number = {shear_inertial_number}",
             f"target_axial_strain = {TARGET}", "frame_strains = [0.03]"]
    if thickness is not None:
        lines.append(f"membrane_thickness = {thickness}")
    return "\n".join(lines) + "\n"


BOUNDARIES = [(f"rate_{PIPELINE_RATE}", "membrane 0.3 mm"), ("membrane_0.6mm", "membrane 0.6 mm"),
              ("membrane_1.0mm", "membrane 1.0 mm"), ("wall", "rigid servo wall")]


def runs(part):
    fidelity = {f"rate_{i}": scene(i) for i in ("1e-3", "3e-3", "1e-2", "3e-2")}
    # The same run on 2 threads: the solver sums per grain in grain order, so the results must be
    # the same as on one thread (a granular sample's dynamics is chaotic: any other summation order
    # would show up as a difference).
    fidelity[REPLICATE] = scene(PIPELINE_RATE)
    # The 0.3 mm membrane at the pipeline's rate is rate_1e-2 (the model's thickness).
    boundary = {f"membrane_{t}mm": scene(PIPELINE_RATE, thickness=f"{t}e-3") for t in ("0.6", "1.0")}
    boundary["wall"] = scene(PIPELINE_RATE, boundary="wall")
    boundary_part = {**boundary, f"rate_{PIPELINE_RATE}": fidelity[f"rate_{PIPELINE_RATE}"]}
    # The longest runs first, so that side by side they do not end alone.
    everything = {REFERENCE: fidelity[REFERENCE], **fidelity, **boundary}
    return {"fidelity": fidelity, "boundary": boundary_part, "all": everything}[part]


def run_all(todo, fdemrun, model, work, jobs, reuse):
    """Runs every scene (at most `jobs` at once, one thread each); returns name -> CPU seconds and
    the names of the runs that failed or were stopped (the others still run and are published)."""
    cpu, failed = {}, []
    pending = [n for n in todo if not (reuse and os.path.exists(os.path.join(work, n + ".h5")))]
    for n in todo:
        if n not in pending:
            cpu[n] = float(open(os.path.join(work, n + ".cpu")).read()) if os.path.exists(os.path.join(work, n + ".cpu")) else math.nan
    running = {}
    while pending or running:
        while pending and len(running) < jobs:
            name = pending.pop(0)
            path = os.path.join(work, name + ".toml")
            with open(path, "w") as f:
                f.write(todo[name])
            log = open(os.path.join(work, name + ".log"), "w")
            threads = "2" if name == REPLICATE else "1"
            cmd = [fdemrun, path, os.path.join(work, name + ".h5"), "--model", model, "-j", threads, "--force"]
            print("running", " ".join(cmd), flush=True)
            running[subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=log).pid] = (name, time.monotonic())
        pid, status, usage = os.wait4(-1, 0)
        if pid not in running:
            continue
        name, start = running.pop(pid)
        if status != 0:
            print(f"fdem_triaxial_bench: {name} failed or was stopped; see {os.path.join(work, name + '.log')}",
                  file=sys.stderr, flush=True)
            failed.append(name)
            continue
        cpu[name] = usage.ru_utime + usage.ru_stime
        with open(os.path.join(work, name + ".cpu"), "w") as f:
            f.write(f"{cpu[name]}\n")
        print(f"{name}: {cpu[name]:.0f} s CPU, {time.monotonic() - start:.0f} s wall", flush=True)
    return cpu, failed


def read(path):
    """The shearing rows of a results file and its last frame's membrane (None inside the wall)."""
    with h5py.File(path, "r") as f:
        s = f["series"]
        shearing = np.isfinite(s["axial_strain"][:])
        out = {k: s[k][:][shearing] for k in ("axial_strain", "volumetric_strain", "stress_ratio", "kinetic_ratio",
                                             "inertial_number", "height", "volume")}
        last = sorted(f["frames"])[-1]
        out["membrane"] = f[f"frames/{last}/membrane/position"][:] if f"frames/{last}/membrane" in f else None
        out["parameters"] = json.loads(f["run/parameters"][0])
    return out


def on_grid(r, key, grid):
    return np.interp(grid, r["axial_strain"], r[key])


def rms_differences(r, base, grid, mean_ratio):
    """RMS differences of sigma_1/sigma_3 (% of mean_ratio) and of eps_v (% strain) between two runs."""
    d_ratio = on_grid(r, "stress_ratio", grid) - on_grid(base, "stress_ratio", grid)
    d_ev = on_grid(r, "volumetric_strain", grid) - on_grid(base, "volumetric_strain", grid)
    return 100 * math.sqrt(np.mean(d_ratio ** 2)) / mean_ratio, 100 * math.sqrt(np.mean(d_ev ** 2))


def fidelity_table(results, cpu):
    grid = np.linspace(0, TARGET, 121)
    ref = results[REFERENCE]
    ref_ratio = on_grid(ref, "stress_ratio", grid)
    rows, points = [], []
    names = sorted((n for n in results if n.startswith("rate_")), key=lambda n: -float(n[5:]))
    for name in names + ([REPLICATE] if REPLICATE in results else []):
        r = results[name]
        # The replicate is compared with the same run on one thread (it must not differ).
        base = results[f"rate_{PIPELINE_RATE}"] if name == REPLICATE else ref
        rms_ratio, rms_ev = rms_differences(r, base, grid, np.mean(ref_ratio))
        t = r["parameters"]["triaxial"]
        label = f"I = {name[5:]}" if name.startswith("rate_") else f"I = {PIPELINE_RATE} on 2 threads, against 1 thread"
        rows.append(f"| {label} | {t['strain_rate']:.3g} | {t['shear_steps']} | {cpu[name]:.0f} | "
                    f"{np.max(r['stress_ratio']):.3f} | {r['volumetric_strain'][-1] * 100:.2f} | "
                    f"{'reference' if name == REFERENCE else f'{rms_ratio:.2f}'} | "
                    f"{'reference' if name == REFERENCE else f'{rms_ev:.3f}'} | {np.max(r['kinetic_ratio']):.3g} |")
        if name.startswith("rate_") and name != REFERENCE:
            points.append((name[5:], cpu[name], rms_ratio, rms_ev))
    head = ("| shearing | strain rate (1/s) | shear steps | CPU s (whole run) | peak sigma_1/sigma_3 | eps_v at 6 % (%) | "
            "RMS difference of sigma_1/sigma_3 from I = 1e-3 (% of mean) | RMS difference of eps_v (% strain) | max kinetic / elastic |\n"
            "|---|---|---|---|---|---|---|---|---|")
    return head + "\n" + "\n".join(rows), points


def fidelity_chart(results, points, path):
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2), dpi=110)
    for name in sorted((n for n in results if n.startswith("rate_")), key=lambda n: float(n[5:])):
        r = results[name]
        a.plot(100 * r["axial_strain"], r["stress_ratio"], label=f"I = {name[5:]}", lw=1)
    a.set_xlabel("axial strain eps_1 (%)")
    a.set_ylabel("sigma_1 / sigma_3")
    a.set_title("Stress ratio at four shearing rates")
    a.grid(alpha=0.3)
    a.legend()
    b.plot([p[1] for p in points], [p[2] for p in points], "o-", label="sigma_1/sigma_3 (% of mean)")
    b.plot([p[1] for p in points], [p[3] for p in points], "s-", label="eps_v (% strain)")
    for label, x, y, _ in points:
        b.annotate(f"I = {label}", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=8)
    b.set_xscale("log")
    b.set_yscale("log")
    b.set_xlabel("CPU time of the whole run (s, one thread)")
    b.set_ylabel("RMS difference from I = 1e-3")
    b.set_title("Accuracy against cost")
    b.grid(True, which="both", alpha=0.3)
    b.legend()
    fig.tight_layout()
    fig.savefig(path)


def boundary_chart(results, path):
    fig, (a, b, c) = plt.subplots(1, 3, figsize=(14, 4.2), dpi=110)
    for name, label in BOUNDARIES:
        if name not in results:
            continue
        r = results[name]
        a.plot(100 * r["axial_strain"], r["stress_ratio"], label=label, lw=1)
        b.plot(100 * r["axial_strain"], 100 * r["volumetric_strain"], label=label, lw=1)
        if r["membrane"] is not None:
            x = r["membrane"]
            axis = x[:, :2].mean(axis=0)
            radius = np.hypot(x[:, 0] - axis[0], x[:, 1] - axis[1]) - r["parameters"]["triaxial"]["ball_radius"]
            order = np.argsort(x[:, 2])
            z, rad = x[order, 2], radius[order]
            bins = np.linspace(z.min(), z.max(), 40)
            which = np.digitize(z, bins)
            zc = [z[which == k].mean() for k in range(1, len(bins)) if np.any(which == k)]
            rc = [rad[which == k].mean() for k in range(1, len(bins)) if np.any(which == k)]
            c.plot(1e3 * np.array(rc), 1e3 * np.array(zc), label=label)
        else:
            h, v = r["height"][-1], r["volume"][-1]
            c.axvline(1e3 * math.sqrt(v / (math.pi * h)), color="k", ls="--", label=label)
    a.set_xlabel("axial strain eps_1 (%)")
    a.set_ylabel("sigma_1 / sigma_3")
    a.set_title("Stress ratio")
    b.set_xlabel("axial strain eps_1 (%)")
    b.set_ylabel("volumetric strain eps_v (%, compression +)")
    b.set_title("Volumetric strain")
    c.set_xlabel("inner radius (mm, ring mean)")
    c.set_ylabel("height z (mm)")
    c.set_title("Deformed shape at eps_1 = 6 %")
    for ax in (a, b, c):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)


def boundary_table(results, cpu):
    rows = []
    for name, label in BOUNDARIES:
        if name not in results:
            continue
        r = results[name]
        t = r["parameters"]["triaxial"]
        rows.append(f"| {label} | {cpu[name]:.0f} | {t['membrane_balls']} | {1e3 * t['ball_radius']:.3f} | "
                    f"{t['membrane_density_scaling']:.3g} | {np.max(r['stress_ratio']):.3f} | {r['stress_ratio'][-1]:.3f} | "
                    f"{100 * r['volumetric_strain'][-1]:.2f} |")
    return ("| boundary | CPU s | balls | ball radius (mm) | density scaling | peak sigma_1/sigma_3 | sigma_1/sigma_3 at 6 % | "
            "eps_v at 6 % (%) |\n|---|---|---|---|---|---|---|---|\n" + "\n".join(rows))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--build", default=os.path.join(SOURCE, "build"))
    p.add_argument("--model", default=os.path.join(SOURCE, "runs", "sand_small", "model.h5"))
    p.add_argument("--work", default=os.path.join(SOURCE, "bench", "out", "fdem_triaxial"))
    p.add_argument("--part", default="all", choices=("all", "fidelity", "boundary"))
    p.add_argument("--jobs", type=int, default=1)
    p.add_argument("--reuse", action="store_true")
    p.add_argument("--publish-only", action="store_true")
    a = p.parse_args()
    fdemrun = os.path.join(a.build, "bin", "fdemrun")
    if not os.path.exists(fdemrun):
        sys.exit(f"fdem_triaxial_bench: {fdemrun} is missing; build it (ninja -C {a.build} fdemrun) or pass --build")
    if not os.path.exists(a.model):
        sys.exit(f"fdem_triaxial_bench: {a.model} is missing; run make -f Makefile.pipeline mesh first or pass --model")
    os.makedirs(a.work, exist_ok=True)
    todo = runs(a.part)
    cpu, failed = ({}, []) if a.publish_only else run_all(todo, fdemrun, a.model, a.work, a.jobs, a.reuse)
    # Tables and charts of every run in WORK, so parts measured separately publish together.
    done = {n for n in runs("all") if os.path.exists(os.path.join(a.work, n + ".h5"))}
    results = {n: read(os.path.join(a.work, n + ".h5")) for n in done}
    for n in done - set(cpu):
        path = os.path.join(a.work, n + ".cpu")
        cpu[n] = float(open(path).read()) if os.path.exists(path) else math.nan
    machine = cpu_model()
    text = ("## fdemrun triaxial test: fidelity and boundary\n\n"
            "The FDEM twin of sand_small (310 grains from the first scan, shapes2mesh), rigid grains unless said, "
            "`pipelines/scenes/triaxial.toml` with one knob changed per run: consolidation to 300 kPa in the servo wall "
            "(servo inertial number 1e-2), the membrane's forming procedure, shearing to eps_1 = 6 % with both platens. "
            f"One thread per run, {a.jobs} run(s) side by side. Measured on {machine}, {os.cpu_count()} cores, "
            f"{date.today()} by `bench/fdem_triaxial_bench.py`.\n\n")
    if REFERENCE in results:
        table, points = fidelity_table(results, cpu)
        fidelity_chart(results, points, os.path.join(SOURCE, "docs", "img", "fdem_triaxial_fidelity.png"))
        text += ("### Shearing rate (inertial number I = strain rate x d50 x sqrt(rho / sigma_3))\n\n" + table +
                 "\n\n![fidelity](img/fdem_triaxial_fidelity.png)\n\n")
    if any(n.startswith("membrane_") or n == "wall" for n in results):
        boundary_chart(results, os.path.join(SOURCE, "docs", "img", "fdem_triaxial_boundary.png"))
        text += (f"### Boundary: membrane thickness and the rigid wall (I = {PIPELINE_RATE})\n\n" + boundary_table(results, cpu) +
                 "\n\n![boundary](img/fdem_triaxial_boundary.png)\n\n")
    publish_runs("fdem_triaxial", text, failed)


if __name__ == "__main__":
    main()
