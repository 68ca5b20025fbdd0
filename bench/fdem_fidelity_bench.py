#!/usr/bin/python3
"""Fidelity of the grains, measured on the pipeline's triaxial twin (runs/<series>/model.h5, the
mesh stage's 10-node meshes): the same scene (pipelines/scenes/triaxial.toml) with only its [model]
kind and the model file's element order changed.

Cases: `rigid` (the pipeline's scene as it is); `rigid_replicate` (the same at 0.98 of the stable
step: the smallest perturbation, so its difference from `rigid` is the chaos floor of one packing);
`tet10` (the model's own 10-node grains, the scene's `kind` line taken out); `tet4` (the same
model with `kind = "tet4"`: each 10-node element split into eight 4-node ones on its own nodes, so the
same nodes and contact surface); `tet4_remeshed` (the same grains meshed again by shapes2mesh with
the pipeline's options and `order = 1`, whose volume target for flat facets makes the mesh finer); `mixed` (a fifth of the
grains deformable, 10-node: the most loaded ones after consolidation, from the rigid run's first
frame; the rest rigid). Deformable grains are integrated as the scene says (deformable_integration).

Each run: fdemrun on one thread, then fdem2forces with the pipeline's options. Measured against the
tet10 twin, the highest fidelity: RMS differences of sigma_1 / sigma_3 (% of its mean) and of eps_v
(% strain) over the shearing; the Kolmogorov-Smirnov distance between the normalised normal-force
distributions f_n / <f_n> of the grain contacts in the last frame; the median relative difference of
the grains' q in the last frame; and each run's Pearson r of stress volatility against D2min. Chart
of accuracy against CPU time: docs/img/fdem_fidelity.png. Prints the table and rewrites the
`fdem_fidelity` section of docs/benchmarks.md.

usage: bench/fdem_fidelity_bench.py [--series NAME] [--build DIR] [--work DIR] [--cases a,b,..] [--jobs N]
                                    [--reuse] [--publish-only]
  --series NAME   the pipeline's series whose model, scans and shapes to use (default sand_small)
  --build DIR     CMake build folder holding bin/fdemrun, bin/fdem2forces, bin/shapes2mesh (default build)
  --work DIR      scratch folder for scenes, models, results and logs (default bench/out/fdem_fidelity)
  --cases LIST    which cases to run (default all: rigid,rigid_replicate,tet10,mixed,tet4,tet4_remeshed)
  --jobs N        runs side by side, one thread each (default 1: CPU times are then comparable)
  --reuse         keep results already in WORK instead of running them again
  --publish-only  run nothing: the table and chart of the results already in WORK"""
import argparse
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
from fdem_triaxial_bench import on_grid, read  # noqa: E402

SOURCE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENE = os.path.join(SOURCE, "pipelines", "scenes", "triaxial.toml")
PARAMS = os.path.join(SOURCE, "pipelines", "params")
CASES = ("rigid", "rigid_replicate", "tet10", "mixed", "tet4", "tet4_remeshed")
REFERENCE = "tet10"
MIXED_SHARE = 0.2
RIGID_LINE = 'kind = "rigid"'


def pipeline_scene():
    text = open(SCENE).read()
    if text.count(RIGID_LINE) != 1:
        sys.exit(f"fdem_fidelity_bench: {SCENE} no longer holds the line {RIGID_LINE} once; update the bench")
    return text


def scene_of(case, work):
    """The pipeline's scene with only what the case changes."""
    text = pipeline_scene()
    if case == "rigid":
        return text
    if case == "rigid_replicate":
        return text.replace("[run]\n", "[run]\ntime_step_fraction = 0.98\n", 1)
    if case in ("tet10", "tet4_remeshed"):
        return text.replace(RIGID_LINE, "# kind: the model file's own")
    if case == "tet4":
        return text.replace(RIGID_LINE, 'kind = "tet4"  # the model file\'s 10-node elements split into 4-node ones on their nodes')
    if case == "mixed":
        rule = ("[model.deformable]\n" 'rule = "most_loaded"\n' f'file = "{os.path.join(work, "rigid.h5")}"\n'
                f"frame = 0\nshare = {MIXED_SHARE}\n")
        return text.replace(RIGID_LINE, "# kind: rigid, but for the grains [model.deformable] picks") + "\n" + rule
    raise ValueError(case)


def model_of(case, series, work):
    return remeshed_model(work) if case == "tet4_remeshed" else os.path.join(SOURCE, "runs", series, "model.h5")


def remeshed_model(work):
    return os.path.join(work, "model_tet4_remeshed.h5")


def make_remeshed_tet4_model(build, series, work):
    """The pipeline's mesh stage again with order = 1 (shapes2mesh's own volume target then sizes the elements)."""
    out = remeshed_model(work)
    scan = os.path.join(SOURCE, "runs", series, "scan_000")
    cmd = [os.path.join(build, "bin", "shapes2mesh"), os.path.join(scan, "shapes.h5"), os.path.join(scan, "labels.h5"), out,
           "--config", os.path.join(PARAMS, "shapes2mesh.toml"), "--order", "1", "--force"]
    print("running", " ".join(cmd), flush=True)
    with open(os.path.join(work, "model_tet4_remeshed.log"), "w") as log:
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=log)


def run_cases(cases, a):
    """Runs the cases in order (`jobs` at a time; mixed waits for rigid, whose first frame picks its
    grains); returns case -> CPU seconds, and the cases that failed."""
    fdemrun = os.path.join(a.build, "bin", "fdemrun")
    cpu, failed, running = {}, [], {}
    pending = [c for c in cases if not (a.reuse and os.path.exists(os.path.join(a.work, c + ".h5")))]
    while pending or running:
        ready = [c for c in pending if c != "mixed" or os.path.exists(os.path.join(a.work, "rigid.h5"))]
        while ready and len(running) < a.jobs:
            case = ready.pop(0)
            pending.remove(case)
            path = os.path.join(a.work, case + ".toml")
            with open(path, "w") as f:
                f.write(scene_of(case, a.work))
            cmd = [fdemrun, path, os.path.join(a.work, case + ".h5"), "--model", model_of(case, a.series, a.work), "-j", "1", "--force"]
            print("running", " ".join(cmd), flush=True)
            log = open(os.path.join(a.work, case + ".log"), "w")
            running[subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=log).pid] = (case, time.monotonic())
        if not running:  # mixed waits for a rigid run that failed
            failed += pending
            break
        pid, status, usage = os.wait4(-1, 0)
        if pid not in running:
            continue
        case, start = running.pop(pid)
        if status != 0:
            print(f"fdem_fidelity_bench: {case} failed; see {os.path.join(a.work, case + '.log')}", file=sys.stderr, flush=True)
            failed.append(case)
            continue
        cpu[case] = usage.ru_utime + usage.ru_stime
        with open(os.path.join(a.work, case + ".cpu"), "w") as f:
            f.write(f"{cpu[case]}\n")
        print(f"{case}: {cpu[case]:.0f} s CPU, {time.monotonic() - start:.0f} s wall", flush=True)
        forces(a, case)
    return cpu, failed


def forces(a, case):
    """fdem2forces on a case's results, with the pipeline's options."""
    cmd = [os.path.join(a.build, "bin", "fdem2forces"), os.path.join(a.work, case + ".h5"), os.path.join(a.work, case + "_forces.h5"),
           "--config", os.path.join(PARAMS, "fdem2forces.toml"), "--force"]
    with open(os.path.join(a.work, case + "_forces.log"), "w") as log:
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=log)


def measure(work, case):
    """What the table compares, from a case's results and forces files."""
    r = read(os.path.join(work, case + ".h5"))
    with h5py.File(os.path.join(work, case + ".h5"), "r") as f:
        kinds = f["grains/kind"][:]
        last = sorted(f["frames"])[-1]
        c = f[f"frames/{last}/contacts"]
        grain_pair = c["platen"][:] < 0
        fn = np.einsum("ij,ij->i", c["force"][:], c["normal"][:])[grain_pair]
        r["normal_force"] = np.sort(np.abs(fn) / np.mean(np.abs(fn)))
        r["steps"] = int(f["series/step"][-1])
        r["kinds"] = kinds
        r["elements"] = f["elements/element"].shape[0]
    with h5py.File(os.path.join(work, case + "_forces.h5"), "r") as f:
        r["q"] = dict(zip(f["grains/label"][:].tolist(), f["grains/q"][:, -1].tolist()))
        r["pearson_r"] = float(f["windows/pearson_r"][0])
    return r


def ks_distance(a, b):
    """Largest gap between the empirical distribution functions of two sorted samples."""
    grid = np.concatenate([a, b])
    return float(np.max(np.abs(np.searchsorted(a, grid, side="right") / len(a) - np.searchsorted(b, grid, side="right") / len(b))))


def against(r, base):
    """Differences of run r from run base: sigma_1/sigma_3 RMS (% of base's mean), eps_v RMS (% strain),
    KS distance of f_n / <f_n>, median |q - q_base| / q_base over the grains both hold."""
    top = min(r["axial_strain"][-1], base["axial_strain"][-1])
    grid = np.linspace(0, top, 200)
    d_ratio = on_grid(r, "stress_ratio", grid) - on_grid(base, "stress_ratio", grid)
    d_ev = on_grid(r, "volumetric_strain", grid) - on_grid(base, "volumetric_strain", grid)
    mean_ratio = float(np.mean(on_grid(base, "stress_ratio", grid)))
    common = [k for k in r["q"] if k in base["q"] and base["q"][k] > 0]
    dq = np.median([abs(r["q"][k] - base["q"][k]) / base["q"][k] for k in common])
    return {"ratio": 100 * math.sqrt(np.mean(d_ratio ** 2)) / mean_ratio, "eps_v": 100 * math.sqrt(np.mean(d_ev ** 2)),
            "ks": ks_distance(r["normal_force"], base["normal_force"]), "q": 100 * float(dq)}


def kinds_text(kinds):
    n = [int(np.sum(kinds == k)) for k in (0, 1, 2)]  # GrainKind: rigid, tet4, tet10
    return " + ".join(f"{v} {name}" for v, name in zip(n, ("rigid", "tet4", "tet10")) if v)


def table(results, cpu):
    rows = ["| case | grains | steps | CPU s | x rigid | peak sigma_1/sigma_3 | final sigma_1/sigma_3 | final eps_v | "
            "RMS diff. sigma_1/sigma_3 | RMS diff. eps_v | KS f_n | median diff. q | r(volatility, D2min) |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    base = results.get(REFERENCE)
    rigid_cpu = cpu.get("rigid", math.nan)
    for case in CASES:
        if case not in results:
            continue
        r = results[case]
        d = against(r, base) if base is not None and case != REFERENCE else None
        if case == "rigid_replicate" and "rigid" in results:
            d = against(r, results["rigid"])
        diff = (f"{d['ratio']:.1f} % | {d['eps_v']:.2f} % | {d['ks']:.3f} | {d['q']:.1f} %" if d else "reference | | | ")
        elements = f" ({r['elements']} elements)" if r["elements"] else ""  # a rigid run's results hold no element stresses
        rows.append(f"| {case} | {kinds_text(r['kinds'])}{elements} | {r['steps']} | {cpu.get(case, math.nan):.0f} | "
                    f"{cpu.get(case, math.nan) / rigid_cpu:.1f} | {np.max(r['stress_ratio']):.3f} | {r['stress_ratio'][-1]:.3f} | "
                    f"{100 * r['volumetric_strain'][-1]:.2f} % | {diff} | {r['pearson_r']:.2f} |")
    return "\n".join(rows)


def chart(results, cpu, path):
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.2))
    for case in CASES:
        if case not in results:
            continue
        r = results[case]
        ax[0].plot(100 * r["axial_strain"], r["stress_ratio"], label=case)
        ax[1].plot(100 * r["axial_strain"], 100 * r["volumetric_strain"], label=case)
    ax[0].set(xlabel="eps_1 (%)", ylabel="sigma_1 / sigma_3", title="stress ratio")
    ax[1].set(xlabel="eps_1 (%)", ylabel="eps_v (%)", title="volumetric strain (dilation < 0)")
    ax[0].legend()
    base = results.get(REFERENCE)
    if base is not None:
        for case in CASES:
            if case in results and case not in (REFERENCE, "rigid_replicate") and case in cpu:
                d = against(results[case], base)
                ax[2].plot(cpu[case], d["ratio"], "o")
                ax[2].annotate(case, (cpu[case], d["ratio"]), textcoords="offset points", xytext=(5, 5))
        if "rigid" in results and "rigid_replicate" in results:
            floor = against(results["rigid_replicate"], results["rigid"])["ratio"]
            ax[2].axhline(floor, color="grey", ls="--", label="chaos floor (rigid at 0.98 of its step)")
            ax[2].legend(loc="lower left", fontsize=8)
        if REFERENCE in cpu:
            ax[2].plot(cpu[REFERENCE], 0, "k*", clip_on=False)
            ax[2].annotate(f"{REFERENCE} (reference)", (cpu[REFERENCE], 0), textcoords="offset points", xytext=(-40, 8))
        ax[2].set_xscale("log")
        ax[2].set_ylim(0, 1.25 * ax[2].get_ylim()[1])
        ax[2].set(xlabel="CPU time (s, one thread)", ylabel=f"RMS diff. of sigma_1/sigma_3 from {REFERENCE} (%)",
                  title="accuracy against cost")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--series", default="sand_small")
    p.add_argument("--build", default=os.path.join(SOURCE, "build"))
    p.add_argument("--work", default=os.path.join(SOURCE, "bench", "out", "fdem_fidelity"))
    p.add_argument("--cases", default=",".join(CASES))
    p.add_argument("--jobs", type=int, default=1)
    p.add_argument("--reuse", action="store_true")
    p.add_argument("--publish-only", action="store_true")
    a = p.parse_args()
    cases = [c for c in a.cases.split(",") if c]
    if unknown := [c for c in cases if c not in CASES]:
        sys.exit(f"fdem_fidelity_bench: unknown case(s) {', '.join(unknown)}; choose from {', '.join(CASES)}")
    for tool in ("fdemrun", "fdem2forces", "shapes2mesh"):
        if not os.path.exists(os.path.join(a.build, "bin", tool)):
            sys.exit(f"fdem_fidelity_bench: {a.build}/bin/{tool} is missing; build it (ninja -C {a.build}) or pass --build")
    model = os.path.join(SOURCE, "runs", a.series, "model.h5")
    if not os.path.exists(model):
        sys.exit(f"fdem_fidelity_bench: {model} is missing; run make -f Makefile.pipeline SERIES={a.series} first")
    os.makedirs(a.work, exist_ok=True)
    cpu, failed = {}, []
    if not a.publish_only:
        if "tet4_remeshed" in cases and not (a.reuse and os.path.exists(remeshed_model(a.work))):
            make_remeshed_tet4_model(a.build, a.series, a.work)
        cpu, failed = run_cases(cases, a)
        with open(os.path.join(a.work, "jobs"), "w") as f:  # what the runs' CPU times were measured under
            f.write(str(a.jobs))
    results = {c: measure(a.work, c) for c in CASES if os.path.exists(os.path.join(a.work, c + "_forces.h5"))}
    for c in results:
        path = os.path.join(a.work, c + ".cpu")
        if c not in cpu and os.path.exists(path):
            cpu[c] = float(open(path).read())
    chart(results, cpu, os.path.join(SOURCE, "docs", "img", "fdem_fidelity.png"))
    machine = cpu_model()
    jobs_path = os.path.join(a.work, "jobs")
    jobs = open(jobs_path).read().strip() if os.path.exists(jobs_path) else str(a.jobs)
    text = ("## Fidelity of the grains: rigid, tet4, tet10 and mixed twins\n\n"
            f"The FDEM twin of {a.series} (runs/{a.series}/model.h5), `pipelines/scenes/triaxial.toml` with only its "
            "[model] kind and the model file's element order changed (cases in `bench/fdem_fidelity_bench.py`). "
            f"Differences are from the {REFERENCE} twin, the highest fidelity; rigid_replicate's from rigid (the chaos floor: "
            "the same run at 0.98 of its step). KS f_n: the Kolmogorov-Smirnov distance of the grain contacts' f_n / <f_n> in "
            "the last frame; q: each grain's deviatoric stress in the last frame (fdem2forces). One thread per run, "
            f"{jobs} run(s) side by side, on {machine}, {os.cpu_count()} cores, {date.today()}.\n\n"
            + table(results, cpu) + "\n\n![accuracy against cost](img/fdem_fidelity.png)\n\n")
    publish_runs("fdem_fidelity", text, failed)


if __name__ == "__main__":
    main()
