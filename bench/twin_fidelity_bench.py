#!/usr/bin/env python3
"""Where the twin's error comes from: the pipeline's FDEM twin of a simulated series against the
series' true stress-strain curve, with the truth swapped in one stage at a time and every case
rerun at shorter time steps to show the scatter of one packing (docs/benchmarks.md, section
twin_fidelity; docs/validate.md, twin line).

Cases, each a twin built from scan 0 and run with pipelines/scenes/triaxial.toml:
- pipeline: the run's own twin (ct2labels, labels2shapes, shapes2mesh);
- pipeline, no cut: the same meshed without shapes2mesh's cut at the neighbours;
- exact labels: the truth's label image (truthswap), then labels2shapes and shapes2mesh;
- + exact shapes: the true SH surfaces of those grains at their measured centroids (truthswap);
- + exact positions: the true surfaces at the true centroids (truthswap --positions);
- + the truth's meshing: those meshed as ctsynth meshes its exact grains (its surface nodes, no cut
  at the neighbours), which leaves the sample cylinder, the fresh membrane and the restart from
  the loaded scan 0 as the twin's only differences from the truth's own run;
- truth replicate: ctsynth's own simulation of the series (the exact grains from the packing)
  rerun at a shorter step: how far the truth scatters from itself, the floor of any twin's error.
Each twin case runs at `--factors` x the stable step ([run] time_step_fraction); fdemrun gives the
same bits on any thread count, so a step a few per cent shorter is the perturbation that shows the
chaos. Every run is scored by the validate tool against the series' truth.

Needs a finished `make -f Makefile.pipeline SERIES=<series>` of a series made with ctsynth
--loading simulated; writes into a new folder under --scratch (printed), links to the run's other
files, and touches nothing else. About 50 minutes on an idle 2-core machine for sand_small.

    python3 bench/twin_fidelity_bench.py [--series sand_small] [--factors 1 0.98 0.96]
        [--truth-factors 0.98 0.96] [--build build] [--scratch /tmp/graintwin_twin_fidelity] [--no-publish]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import tomllib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_doc import SOURCE, finish  # noqa: E402

SCENE = os.path.join(SOURCE, "pipelines", "scenes", "triaxial.toml")
PARAMS = os.path.join(SOURCE, "pipelines", "params")
SWAPS = ["pipeline", "pipeline, no cut", "exact labels", "+ exact shapes", "+ exact positions", "+ the truth's meshing"]


def run(cmd, cwd=None):
    started = time.time()
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=cwd)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{r.stderr[-2000:]}")
    return time.time() - started


def params(series, tool):
    """The stage's params file as Makefile.pipeline picks it."""
    own = os.path.join(PARAMS, series, tool + ".toml")
    return own if os.path.exists(own) else os.path.join(PARAMS, tool + ".toml")


def scene_at(folder, factor):
    """The pipeline's triaxial scene with the automatic step at `factor` x the stable limit."""
    path = os.path.join(folder, f"triaxial_{factor:g}.toml")
    with open(path, "w") as f:
        f.write(open(SCENE).read().replace("[run]\n", f"[run]\ntime_step_fraction = {factor!r}\n", 1))
    return path


def run_folder(scratch, name, run_dir):
    """A folder holding links to the run's files but its simulation and validation."""
    folder = os.path.join(scratch, name)
    os.makedirs(folder)
    for entry in os.listdir(run_dir):
        if entry not in ("simulation.h5", "validation.json", "model.h5"):
            os.symlink(os.path.abspath(os.path.join(run_dir, entry)), os.path.join(folder, entry))
    return folder


def score(a, folder):
    out = os.path.join(folder, "validation.json")
    run([f"{a.build}/bin/validate", folder, os.path.join(SOURCE, "sample_volumes", a.series), out, "-q"])
    return json.load(open(out))["twin"]


def swap_models(a, scratch, run_dir):
    """The model of every case: the run's, then each swap's built by the pipeline's own stages."""
    bin_ = f"{a.build}/bin"
    series_dir = os.path.join(SOURCE, "sample_volumes", a.series)
    truth, scan = os.path.join(series_dir, "truth_000.h5"), os.path.join(series_dir, "scan_000.h5")
    work = os.path.join(scratch, "swaps")
    os.makedirs(work)
    labels = os.path.join(work, "labels_true.h5")
    shapes = {case: os.path.join(work, f"shapes_{name}.h5") for case, name in
              (("exact labels", "from_true_labels"), ("+ exact shapes", "true_surfaces"), ("+ exact positions", "true_poses"))}
    run([f"{bin_}/truthswap", truth, os.path.join(run_dir, "scan_000", "labels.h5"), labels, "-q"])
    run([f"{bin_}/labels2shapes", labels, scan, shapes["exact labels"], "--config", params(a.series, "labels2shapes"), "-q"])
    run([f"{bin_}/truthswap", truth, shapes["exact labels"], shapes["+ exact shapes"], "--labels", labels, "-q"])
    run([f"{bin_}/truthswap", truth, shapes["exact labels"], shapes["+ exact positions"], "--labels", labels, "--positions", "-q"])
    # The truth's own meshing (ctsynth meshes the exact surfaces with its --simulated-surface-nodes and
    # no cut at the neighbours: they are not segmented): what is left is the sample cylinder, the
    # fresh membrane and the restart from the loaded scan 0.
    with open(os.path.join(series_dir, "scene.toml"), "rb") as f:
        surface_nodes = tomllib.load(f).get("simulated-surface-nodes", 500)
    shapes["+ the truth's meshing"] = shapes["+ exact positions"]
    truth_meshing = ["--surface-nodes", f"{surface_nodes:g}", "--cut-at-neighbours", "false"]
    models = {"pipeline": os.path.join(run_dir, "model.h5"), "pipeline, no cut": os.path.join(work, "model_no_cut.h5")}
    run([f"{bin_}/shapes2mesh", os.path.join(run_dir, "scan_000", "shapes.h5"), os.path.join(run_dir, "scan_000", "labels.h5"),
         models["pipeline, no cut"], "--config", params(a.series, "shapes2mesh"), "--cut-at-neighbours", "false", "-q"])
    for case, s in shapes.items():
        models[case] = os.path.join(work, f"model_{len(models)}.h5")
        run([f"{bin_}/shapes2mesh", s, labels, models[case], "--config", params(a.series, "shapes2mesh"), "-q"] +
            (truth_meshing if case == "+ the truth's meshing" else []))
    return models


def truth_replicate(a, scratch, run_dir, factor):
    """ctsynth's simulation of the series rerun at `factor` x the step, scored as a twin."""
    series_dir = os.path.join(SOURCE, "sample_volumes", a.series)
    out = os.path.join(scratch, f"truth_series_{factor:g}")
    seconds = run([f"{a.build}/bin/ctsynth", os.path.join(series_dir, "scene.toml"), out, "--triaxial-scene",
                   scene_at(scratch, factor), "--keep-simulation", "-q"], cwd=SOURCE)
    folder = run_folder(scratch, f"truth_replicate_{factor:g}", run_dir)
    os.symlink(os.path.join(out, "simulation.h5"), os.path.join(folder, "simulation.h5"))
    return score(a, folder), seconds


def chart(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a, b, c) = plt.subplots(1, 3, figsize=(15, 4.2))
    truth = rows[0]["twin"]
    a.plot([100 * e for e in truth["axial_strain"]], truth["stress_ratio_true"], "k-", lw=2.5, label="truth")
    b.plot([100 * e for e in truth["axial_strain"]], [100 * v for v in truth["volumetric_strain_true"]], "k-", lw=2.5, label="truth")
    cases = list(dict.fromkeys(r["case"] for r in rows))
    colours = {case: plt.cm.tab10(k) for k, case in enumerate(cases)}
    for r in rows:
        t, label = r["twin"], r["case"] if r["factor"] == max(q["factor"] for q in rows if q["case"] == r["case"]) else None
        a.plot([100 * e for e in t["axial_strain"]], t["stress_ratio"], lw=1, color=colours[r["case"]], label=label)
        b.plot([100 * e for e in t["axial_strain"]], [100 * v for v in t["volumetric_strain"]], lw=1, color=colours[r["case"]], label=label)
    a.set(xlabel="axial strain (%)", ylabel="sigma_1 / sigma_3", title="Stress ratio")
    b.set(xlabel="axial strain (%)", ylabel="volumetric strain ln(V0/V) (%)", title="Volumetric strain (+: contraction)")
    for k, case in enumerate(cases):
        rms = [100 * r["twin"]["stress_ratio_rms_rel"] for r in rows if r["case"] == case]
        dev = [100 * r["twin"]["volumetric_strain_max_abs"] for r in rows if r["case"] == case]
        c.plot([k - 0.12] * len(rms), rms, "o", color=colours[case])
        c.plot([k + 0.12] * len(dev), dev, "s", mfc="none", color=colours[case])
    c.axhline(5, color="grey", ls="--", lw=1)
    c.axhline(0.2, color="grey", ls=":", lw=1)
    c.set_xticks(range(len(cases)), cases, rotation=20, fontsize=8)
    c.set(ylabel="error (%)", yscale="log",
          title="o stress ratio RMS, [] largest eps_v error\n(dashed 5 %, dotted 0.2 %: the targets)")
    for ax in (a, b, c):
        ax.grid(alpha=0.3)
    a.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--series", default="sand_small")
    p.add_argument("--factors", nargs="+", type=float, default=[1.0, 0.98, 0.96])
    p.add_argument("--truth-factors", nargs="*", type=float, default=[0.98, 0.96])
    p.add_argument("--build", default=os.path.join(SOURCE, "build"))
    p.add_argument("--scratch", default=os.path.join(tempfile.gettempdir(), "graintwin_twin_fidelity"))
    p.add_argument("--no-publish", action="store_true")
    a = p.parse_args()
    run_dir = os.path.join(SOURCE, "runs", a.series)
    for needed in ("simulation.h5", "model.h5", "validation.json", os.path.join("scan_000", "labels.h5")):
        if not os.path.exists(os.path.join(run_dir, needed)):
            sys.exit(f"{run_dir}/{needed} is missing; run make -f Makefile.pipeline SERIES={a.series} first")
    if not json.load(open(os.path.join(run_dir, "validation.json")))["twin"].get("simulated"):
        sys.exit(f"sample_volumes/{a.series} is not a simulated series (ctsynth --loading simulated): no curve to score the twin on")
    os.makedirs(a.scratch, exist_ok=True)
    scratch = tempfile.mkdtemp(prefix="run.", dir=a.scratch)
    print("writing into", scratch)
    models = swap_models(a, scratch, run_dir)
    replicates = []
    for factor in a.truth_factors:
        twin, seconds = truth_replicate(a, scratch, run_dir, factor)
        replicates.append({"case": "truth replicate", "factor": factor, "seconds": seconds, "twin": twin})
        print(f"truth replicate, {factor:g} x step: stress ratio RMS {twin['stress_ratio_rms_rel']:.4f}, "
              f"eps_v within {twin['volumetric_strain_max_abs']:.4f} ({seconds:.0f} s)", flush=True)
    rows = []
    for case in SWAPS:
        for factor in a.factors:
            folder = run_folder(scratch, f"{SWAPS.index(case)}_{factor:g}", run_dir)
            seconds = run([f"{a.build}/bin/fdemrun", scene_at(folder, factor), os.path.join(folder, "simulation.h5"),
                           "--model", models[case], "--config", params(a.series, "fdemrun"), "-q"])
            rows.append({"case": case, "factor": factor, "seconds": seconds, "twin": score(a, folder)})
            t = rows[-1]["twin"]
            print(f"{case}, {factor:g} x step: stress ratio RMS {t['stress_ratio_rms_rel']:.4f}, "
                  f"eps_v within {t['volumetric_strain_max_abs']:.4f} ({seconds:.0f} s)", flush=True)
    rows += replicates
    chart(rows, os.path.join(SOURCE, "docs", "img", "twin_fidelity.png"))
    publish_text(a, rows, scratch)


def publish_text(a, rows, scratch):
    lines = [f"Where the error of `{a.series}`'s FDEM twin comes from. Every case is a twin built from scan 0 and "
             f"sheared with `pipelines/scenes/triaxial.toml`, scored by `validate` against the series' true curve "
             f"(docs/validate.md, twin line). The truth is swapped in one stage at a time with `truthswap`: "
             f"exact labels, then exact SH surfaces at the measured centroids, then at the true centroids, then "
             f"meshed as ctsynth meshes its exact grains. Each "
             f"case is rerun at shorter steps (`time_step_fraction`), so its spread is the chaos of one packing. "
             f"The truth replicate is ctsynth's own simulation of the series rerun at a shorter step: the truth "
             f"against itself, the floor of any twin's error. Regenerate: `python3 bench/twin_fidelity_bench.py "
             f"--series {a.series}` after the pipeline.", "",
             "| case | time step | stress ratio RMS, relative | largest volumetric strain error | run (wall) |",
             "|---|---|---|---|---|"]
    for r in rows:
        t = r["twin"]
        lines.append(f"| {r['case']} | {r['factor']:g} x the stable step | {t['stress_ratio_rms_rel']:.4f} | "
                     f"{t['volumetric_strain_max_abs']:.4f} | {r['seconds']:.0f} s |")
    lines += ["", "| case | stress ratio RMS: mean (range) | volumetric strain error: mean (range) |", "|---|---|---|"]
    for case in dict.fromkeys(r["case"] for r in rows):
        rms = [r["twin"]["stress_ratio_rms_rel"] for r in rows if r["case"] == case]
        dev = [r["twin"]["volumetric_strain_max_abs"] for r in rows if r["case"] == case]
        lines.append(f"| {case} | {sum(rms) / len(rms):.3f} ({min(rms):.3f} to {max(rms):.3f}) | "
                     f"{sum(dev) / len(dev):.4f} ({min(dev):.4f} to {max(dev):.4f}) |")
    lines += ["", "![truth, twins with the truth swapped in, and the error of each case](img/twin_fidelity.png)", ""]
    finish("twin_fidelity", "\n".join(lines), scratch, rows, not a.no_publish)


if __name__ == "__main__":
    main()
