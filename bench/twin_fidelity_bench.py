#!/usr/bin/env python3
"""The twin against the truth, with the run-to-run scatter of the twin itself: the pipeline's
triaxial test of a simulated series' twin (runs/<series>/simulation.h5), rerun at shorter time
steps, each run scored against the series' ground-truth curve by the validate tool (docs/validate.md,
twin line; docs/benchmarks.md, section twin_fidelity).

fdemrun gives the same bits on any thread count, so a step a few per cent shorter is the
perturbation that shows how far one packing's curve scatters on its own (as in
bench/fdem_mass_scaling_bench.py): an error of the twin below that scatter cannot be told from
chaos. Needs a finished `make -f Makefile.pipeline SERIES=<series>` of a series made with ctsynth
--loading simulated; each rerun writes into a new folder under --scratch (printed), with links to
the run's other files, and nothing else is touched.

    python3 bench/twin_fidelity_bench.py [--series sand_small] [--factors 1 0.98 0.96]
        [--build build] [--scratch /tmp/graintwin_twin_fidelity] [--no-publish]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import h5py

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_doc import SOURCE, finish  # noqa: E402

SCENE = os.path.join(SOURCE, "pipelines", "scenes", "triaxial.toml")
FDEMRUN_PARAMS = os.path.join(SOURCE, "pipelines", "params", "fdemrun.toml")


def run(cmd):
    started = time.time()
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{r.stderr[-2000:]}")
    return time.time() - started


def stable_step(simulation):
    with h5py.File(simulation, "r") as f:
        return json.loads(f["run/parameters"][0])["time_step"]


def replicate(build, scratch, run_dir, series, factor, step):
    """A run folder whose simulation.h5 is the twin's test at `factor` x its stable step, and its
    validation.json; returns the twin line and fdemrun's wall seconds (0 for the pipeline's run)."""
    folder = os.path.join(scratch, f"{series}.{factor}")
    os.makedirs(folder)
    for entry in os.listdir(run_dir):
        if entry not in ("simulation.h5", "validation.json"):
            os.symlink(os.path.abspath(os.path.join(run_dir, entry)), os.path.join(folder, entry))
    simulation = os.path.join(folder, "simulation.h5")
    seconds = 0.0
    if factor == 1:
        os.symlink(os.path.abspath(os.path.join(run_dir, "simulation.h5")), simulation)
    else:
        scene = os.path.join(folder, "triaxial.toml")
        with open(scene, "w") as f:
            f.write(open(SCENE).read().replace("[run]\n", f"[run]\ntime_step = {factor * step!r}\n", 1))
        seconds = run([f"{build}/bin/fdemrun", scene, simulation, "--model", os.path.join(run_dir, "model.h5"),
                       "--config", FDEMRUN_PARAMS, "-q"])
    out = os.path.join(folder, "validation.json")
    run([f"{build}/bin/validate", folder, os.path.join(SOURCE, "sample_volumes", series), out, "-q"])
    return json.load(open(out))["twin"], seconds


def chart(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    truth = rows[0]["twin"]
    a.plot([100 * e for e in truth["axial_strain"]], truth["stress_ratio_true"], "k-", lw=2, label="truth")
    b.plot([100 * e for e in truth["axial_strain"]], [100 * v for v in truth["volumetric_strain_true"]], "k-", lw=2, label="truth")
    for r in rows:
        t = r["twin"]
        name = f"twin, {r['factor']:g} x step"
        a.plot([100 * e for e in t["axial_strain"]], t["stress_ratio"], lw=1, label=name)
        b.plot([100 * e for e in t["axial_strain"]], [100 * v for v in t["volumetric_strain"]], lw=1, label=name)
    a.set(xlabel="axial strain (%)", ylabel="sigma_1 / sigma_3", title="Stress ratio")
    b.set(xlabel="axial strain (%)", ylabel="volumetric strain ln(V0/V) (%)", title="Volumetric strain")
    for ax in (a, b):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--series", default="sand_small")
    p.add_argument("--factors", nargs="+", type=float, default=[1.0, 0.98, 0.96])
    p.add_argument("--build", default=os.path.join(SOURCE, "build"))
    p.add_argument("--scratch", default=os.path.join(tempfile.gettempdir(), "graintwin_twin_fidelity"))
    p.add_argument("--no-publish", action="store_true")
    a = p.parse_args()
    run_dir = os.path.join(SOURCE, "runs", a.series)
    for needed in ("simulation.h5", "model.h5", "validation.json"):
        if not os.path.exists(os.path.join(run_dir, needed)):
            sys.exit(f"{run_dir}/{needed} is missing; run make -f Makefile.pipeline SERIES={a.series} first")
    os.makedirs(a.scratch, exist_ok=True)
    scratch = tempfile.mkdtemp(prefix="run.", dir=a.scratch)
    print("writing into", scratch)
    step = stable_step(os.path.join(run_dir, "simulation.h5"))
    rows = []
    for factor in a.factors:
        twin, seconds = replicate(a.build, scratch, run_dir, a.series, factor, step)
        if not twin.get("simulated"):
            sys.exit(f"sample_volumes/{a.series} is not a simulated series (ctsynth --loading simulated): no curve to score the twin on")
        rows.append({"factor": factor, "step": factor * step, "seconds": seconds, "twin": twin})
        print(f"{factor:g} x step: stress ratio RMS {twin['stress_ratio_rms_rel']:.4f}, eps_v within {twin['volumetric_strain_max_abs']:.4f}")
    img = os.path.join(SOURCE, "docs", "img", "twin_fidelity.png")
    chart(rows, img)
    rms = [r["twin"]["stress_ratio_rms_rel"] for r in rows]
    dev = [r["twin"]["volumetric_strain_max_abs"] for r in rows]
    lines = [f"The FDEM twin of `{a.series}` (the pipeline's run: shapes2mesh from scan 0, `pipelines/scenes/triaxial.toml`) "
             f"against the series' true stress-strain curve, by `validate` (twin line, docs/validate.md), rerun at shorter "
             f"time steps: the spread of these runs is the scatter of one packing, which bounds what any twin can be held to. "
             f"Regenerate: `python3 bench/twin_fidelity_bench.py --series {a.series}` after the pipeline.", "",
             "| twin run | time step | stress ratio RMS, relative | largest volumetric strain error | axial strain range | fdemrun (wall) |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        t = r["twin"]
        lines.append(f"| {r['factor']:g} x the stable step | {r['step']:.4g} s | {t['stress_ratio_rms_rel']:.4f} | "
                     f"{t['volumetric_strain_max_abs']:.4f} | 0 to {t['axial_strain_max']:.3f} | "
                     f"{'the pipeline' if r['factor'] == 1 else format(r['seconds'], '.0f') + ' s'} |")
    lines += ["", f"Across the runs: stress ratio RMS {min(rms):.3f} to {max(rms):.3f}; volumetric strain error "
              f"{min(dev):.4f} to {max(dev):.4f}.", "", "![truth and twin runs](img/twin_fidelity.png)", ""]
    finish("twin_fidelity", "\n".join(lines), scratch, rows, not a.no_publish)


if __name__ == "__main__":
    main()
