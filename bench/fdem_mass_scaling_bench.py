#!/usr/bin/env python3
"""Mass scaling against run-to-run scatter: the pipeline's triaxial test of a twin with and without
fdemrun's [run] mass_scaled_share, each at the stable step and at 0.98 times it (docs/benchmarks.md,
section fdem_mass_scaling; docs/fdemrun.md, mass scaling).

fdemrun gives the same bits on any thread count, so a step 2 % shorter is the perturbation that shows
how far a small packing's result scatters on its own; the scaling is worth its speed only where it
moves the result by less than that. Each run reads the model of `make -f Makefile.pipeline
SERIES=<series> mesh` (runs/<series>/model.h5, made first when missing) and writes into a new folder
under --scratch (printed; nothing else there is touched).

    python3 bench/fdem_mass_scaling_bench.py [--series sand_small soil_crop] [--shares 0 0.05]
        [--build build] [--scratch /tmp/graintwin_mass_scaling] [--no-publish]
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_doc import SOURCE, finish  # noqa: E402

SCENE = os.path.join(SOURCE, "pipelines", "scenes", "triaxial.toml")
PERTURBED = 0.98


def scene_text(share, step):
    text = open(SCENE).read()
    text, n = re.subn(r"(?m)^mass_scaled_share = .*$", f"mass_scaled_share = {share}", text)
    if n != 1:
        sys.exit(f"{SCENE} has no 'mass_scaled_share = ' line to vary")
    if step > 0:
        text = text.replace("[run]\n", f"[run]\ntime_step = {step!r}\n", 1)
    return text


def fdemrun(build, scene, out, model, extra=()):
    started = time.time()
    r = subprocess.run([f"{build}/bin/fdemrun", scene, out, "--model", model, "--force", *extra], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"fdemrun {scene} failed:\n{r.stderr[-2000:]}")
    return r.stderr, time.time() - started


def one(build, run_dir, series, share, factor):
    model = os.path.join(SOURCE, "runs", series, "model.h5")
    name = f"{series}.{share}.{factor}"
    scene = os.path.join(run_dir, name + ".toml")
    step = 0.0
    if factor != 1:  # the run's own stable step, from a run stopped at its first step
        with open(scene, "w") as f:
            f.write(scene_text(share, 0.0))
        log, _ = fdemrun(build, scene, os.path.join(run_dir, "probe.h5"), model, ["--stop-step", "1"])
        step = factor * float(re.search(r"time step ([0-9.e+-]+) s", log).group(1))
    with open(scene, "w") as f:
        f.write(scene_text(share, step))
    log, seconds = fdemrun(build, scene, os.path.join(run_dir, name + ".h5"), model)
    ratio = re.search(r"sigma_1 / sigma_3 ([0-9.]+), eps_v ([-0-9.e]+)", log)
    scaled = re.search(r"(\d+) grains \(([0-9.e+-]+) % of the mass\) made up to ([0-9.e+-]+) times denser", log)
    return {"series": series, "share": share, "factor": factor, "step": float(re.search(r"time step ([0-9.e+-]+) s", log).group(1)),
            "ratio": float(ratio.group(1)), "eps_v": float(ratio.group(2)), "seconds": seconds,
            "scaled_grains": int(scaled.group(1)) if scaled else 0, "mass_percent": float(scaled.group(2)) if scaled else 0.0,
            "largest_factor": float(scaled.group(3)) if scaled else 1.0}


def table(rows, shares):
    out = ["| twin | `mass_scaled_share` | grains scaled (mass, largest factor) | step | sigma_1 / sigma_3 at 6 %: stable step; 0.98 x it | eps_v | fdemrun (wall) |",
           "|---|---|---|---|---|---|---|"]
    for series in dict.fromkeys(r["series"] for r in rows):
        for share in shares:
            pair = [r for r in rows if r["series"] == series and r["share"] == share]
            a, b = pair[0], pair[1]
            scaled = f"{a['scaled_grains']} ({a['mass_percent']:.2g} %, {a['largest_factor']:.2g} x)" if a["scaled_grains"] else "none"
            out.append(f"| {series} | {share} | {scaled} | {a['step']:.3g} s | {a['ratio']:.3f}; {b['ratio']:.3f} | "
                       f"{a['eps_v']:.4f}; {b['eps_v']:.4f} | {a['seconds']:.0f} s |")
    return "\n".join(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--series", nargs="+", default=["sand_small", "soil_crop"])
    ap.add_argument("--shares", nargs="+", type=float, default=[0.0, 0.05])
    ap.add_argument("--build", default=os.path.join(SOURCE, "build"))
    ap.add_argument("--scratch", default="/tmp/graintwin_mass_scaling")
    ap.add_argument("--no-publish", action="store_true")
    a = ap.parse_args()
    build = os.path.abspath(a.build)
    for series in a.series:
        if not os.path.exists(os.path.join(SOURCE, "runs", series, "model.h5")):
            subprocess.run(["make", "-s", "-f", "Makefile.pipeline", f"SERIES={series}", f"BIN={build}/bin", "mesh"], cwd=SOURCE, check=True)
    os.makedirs(a.scratch, exist_ok=True)
    run_dir = tempfile.mkdtemp(prefix="mass_scaling-", dir=a.scratch)
    print(f"outputs in {run_dir}", flush=True)
    rows = []
    for series in a.series:
        for share in a.shares:
            for factor in (1, PERTURBED):
                rows.append(one(build, run_dir, series, share, factor))
                print(json.dumps(rows[-1]), flush=True)
    text = ("The pipeline's triaxial test (`pipelines/scenes/triaxial.toml`) of each twin with and without density "
            "scaling of the grains that set the time step, at the stable step and at 0.98 times it "
            f"(`python3 bench/fdem_mass_scaling_bench.py`; {os.cpu_count()} cores, {time.strftime('%Y-%m-%d')}). "
            "fdemrun gives the same bits on any thread count: the shorter step is what shows a small packing's "
            "own scatter.\n\n" + table(rows, a.shares) + "\n")
    finish("fdem_mass_scaling", text, run_dir, rows, not a.no_publish)


if __name__ == "__main__":
    main()
