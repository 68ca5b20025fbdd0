#!/usr/bin/env python3
"""Time per grain of every pipeline stage, series by series, side by side (docs/benchmarks.md,
section pipeline_stages), with the share of grains on each meshing path.

Runs Makefile.pipeline's stages one after another (inspect, segment, contacts, shapes, mesh; and
simulate with --simulate) into a scratch folder for each series, and measures each stage's wall
time and CPU time (user + system of its processes). Per grain: CPU time over the grains the stage
handled (every scan's grains for the per-scan stages, the reference scan's for mesh and simulate).
Each run writes into a new folder of its own under --scratch (printed; nothing else there is touched).

    python3 bench/pipeline_stages_bench.py [--series sand_small sand_angular soil_crop] [--simulate]
        [--build build] [--scratch /tmp/graintwin_stages] [--no-publish]
"""
import argparse
import glob
import os
import tempfile
import subprocess
import sys
import time

import h5py

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_doc import SOURCE, finish  # noqa: E402

PER_SCAN = ("inspect", "segment", "contacts", "shapes")
PATH_NAMES = ("gmsh remeshed", "kept surface", "ellipsoid")
ORIGIN_NAMES = ("SH fit", "voxels", "ellipsoid")


def run_measured(cmd, log=None):
    """Runs cmd from the source folder: its wall and CPU seconds (user + system of all its
    processes) and the peak resident memory, in bytes, of the largest of them (wait4's rusage
    covers every process the command waited for). Its stderr goes to the file `log` when given
    (to follow a long run), else to memory. Exits with the command's stderr if it fails."""
    t0 = time.perf_counter()
    with open(log, "w") if log else open(os.devnull, "w") as sink:
        proc = subprocess.Popen(cmd, cwd=SOURCE, stdout=subprocess.DEVNULL,
                                stderr=sink if log else subprocess.PIPE, text=True)
        err = "" if log else proc.stderr.read()
        _, status, usage = os.wait4(proc.pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        if log:
            with open(log) as f:
                err = f.read()
        sys.exit(f"{' '.join(cmd)} failed:\n{err.strip()[-3000:]}")
    return time.perf_counter() - t0, usage.ru_utime + usage.ru_stime, usage.ru_maxrss * 1024


def run_stage(series, stage, out, build, inp=None, make_options=()):
    """One Makefile.pipeline stage of a series from sample_volumes/ (or from the folder `inp`),
    measured by run_measured(); `make_options` go to make as they are (variables, -o FILE)."""
    cmd = ["make", "-s", "-f", "Makefile.pipeline", f"SERIES={series}", f"OUT={out}", f"BIN={build}/bin"]
    return run_measured(cmd + ([f"IN={inp}"] if inp else []) + list(make_options) + [stage])


def grains_of(labels_path):
    with h5py.File(labels_path, "r") as f:
        return int(f["grains/label"].shape[0])


def mesh_paths(model_path):
    with h5py.File(model_path, "r") as f:
        path = f["mesh/path"][:]
        origin = f["mesh/surface_origin"][:]
        overran = int(f["mesh/overran_budget"][:].sum())
        seconds = f["mesh/seconds"][:]
    return {
        "paths": [int((path == k).sum()) for k in range(len(PATH_NAMES))],
        "origins": [int((origin == k).sum()) for k in range(len(ORIGIN_NAMES))],
        "overran": overran,
        "slowest_s": float(seconds.max()),
    }


def bench_series(series, stages, build, run_dir):
    folder = os.path.join(SOURCE, "sample_volumes", series)
    scans = sorted(glob.glob(os.path.join(folder, "scan_*.h5")))
    if not scans:
        sys.exit(f"pipeline_stages_bench: no scans in {folder}; pick series from sample_volumes/")
    out = os.path.join(run_dir, series)
    rows = {}
    for stage in stages:
        wall, cpu, _ = run_stage(series, stage, out, build)
        rows[stage] = {"wall_s": wall, "cpu_s": cpu}
        print(f"{series:14s} {stage:9s} wall {wall:7.2f} s  cpu {cpu:7.2f} s", flush=True)
    names = [os.path.splitext(os.path.basename(s))[0] for s in scans]
    per_scan = [grains_of(os.path.join(out, n, "labels.h5")) for n in names]
    for stage, row in rows.items():
        row["grains"] = sum(per_scan) if stage in PER_SCAN else per_scan[0]
        row["cpu_ms_per_grain"] = 1e3 * row["cpu_s"] / row["grains"]
    result = {"scans": len(scans), "grains": per_scan[0], "stages": rows}
    if "contacts" in rows:
        contacts = 0
        for n in names:
            with h5py.File(os.path.join(out, n, "contacts.h5"), "r") as f:
                contacts += int(f["contacts/pair"].shape[0])
        result["contacts"] = contacts
    if "mesh" in rows:
        result["mesh"] = mesh_paths(os.path.join(out, "model.h5"))
    return result


def table(results, stages):
    series = list(results)
    lines = ["| stage | " + " | ".join(f"{s}: wall s / CPU s / CPU ms per grain" for s in series) + " |",
             "|---|" + "---|" * len(series)]
    for stage in stages:
        cells = []
        for s in series:
            r = results[s]["stages"].get(stage)
            cells.append("-" if r is None else f"{r['wall_s']:.1f} / {r['cpu_s']:.1f} / {r['cpu_ms_per_grain']:.1f}")
        lines.append(f"| {stage} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def targets(results):
    """The measures against the stages' speed targets for real scans."""
    lines = ["| series | contacts: wall ms per contact (target 1) | mesh: CPU ms per grain (target 100 per core) |", "|---|---|---|"]
    for s, r in results.items():
        c, m = r["stages"].get("contacts"), r["stages"].get("mesh")
        per_contact = f"{1e3 * c['wall_s'] / r['contacts']:.2f} ({1e3 * c['wall_s'] / r['contacts']:.2f} x target)" if c and r.get("contacts") else "-"
        per_grain = f"{m['cpu_ms_per_grain']:.0f} ({m['cpu_ms_per_grain'] / 100:.2f} x target)" if m else "-"
        lines.append(f"| {s} | {per_contact} | {per_grain} |")
    return "\n".join(lines)


def mesh_table(results):
    lines = ["| series | grains | on each path (" + ", ".join(PATH_NAMES) + ") | surface from ("
             + ", ".join(ORIGIN_NAMES) + ") | over the budget | slowest grain, s |", "|---|---|---|---|---|---|"]
    for s, r in results.items():
        m = r.get("mesh")
        if not m:
            continue
        share = lambda counts: ", ".join(f"{c} ({100.0 * c / r['grains']:.0f} %)" for c in counts)  # noqa: E731
        lines.append(f"| {s} | {r['grains']} | {share(m['paths'])} | {share(m['origins'])} | {m['overran']} | {m['slowest_s']:.2f} |")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--series", nargs="+", default=["sand_small", "sand_angular", "soil_crop"])
    ap.add_argument("--simulate", action="store_true", help="also time the simulate stage (minutes per series)")
    ap.add_argument("--build", default=os.path.join(SOURCE, "build"))
    ap.add_argument("--scratch", default="/tmp/graintwin_stages")
    ap.add_argument("--no-publish", action="store_true")
    a = ap.parse_args()
    stages = ["inspect", "segment", "contacts", "shapes", "mesh"] + (["simulate"] if a.simulate else [])
    os.makedirs(a.scratch, exist_ok=True)
    run_dir = tempfile.mkdtemp(prefix="pipeline_stages-", dir=a.scratch)
    print(f"outputs in {run_dir}", flush=True)
    results = {s: bench_series(s, stages, os.path.abspath(a.build), run_dir) for s in a.series}
    text = (
        "Time of each pipeline stage per grain, on 2 cores (`python3 bench/pipeline_stages_bench.py`; "
        f"{os.cpu_count()} cores here, {time.strftime('%Y-%m-%d')}). Wall and CPU (user + system) seconds of the "
        "stage's processes, and CPU milliseconds per grain (the per-scan stages over every scan's grains, mesh"
        + (" and simulate" if a.simulate else "") + " over the reference scan's).\n\n"
        + table(results, stages) + "\n\nAgainst the speed targets for real scans (labels2contacts at most 1 ms per "
        "contact, shapes2mesh at most 0.1 s per grain per core):\n\n" + targets(results) + "\n\nMeshing paths (shapes2mesh, `/mesh/path`, `/mesh/surface_origin`):\n\n"
        + mesh_table(results) + "\n")
    finish("pipeline_stages", text, run_dir, results, not a.no_publish)


if __name__ == "__main__":
    main()
