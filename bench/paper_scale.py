#!/usr/bin/env python3
"""Paper scale: every stage's cost as the sample grows from the bundled 310 grains toward the
reference experiment's size (docs/benchmarks.md, section paper_scale).

Cases: the bundled series sand_small, then samples made by ctsynth from
pipelines/scenes/paper_scale.toml (the experiment's cylinder, voxel size, void ratio and grading)
with the cylinder scaled to each of --diameters (mm; the height keeps the experiment's 25:12).
For each case the bench runs ctsynth (stage "synth": packing and rendering the scans) and then
Makefile.pipeline's stages one after another (--stages), and records each stage's wall time, CPU
time (user + system of all its processes), peak resident memory (its largest process) and the
bytes it wrote. Between consecutive cases it gives each stage's growth exponent: the slope of CPU
time against the reference scan's grain count on log-log axes (1 is linear; N log N from 300 to
16 000 grains shows as about 1.2).

The simulate stage (fdemrun's triaxial test of the twin with the pipeline's scene, to 10 % axial
strain, or to --simulate-strain: 0.18 is the experiment's last scan) runs when named in --stages;
its row also gets fdemrun's own accounts of the steps (grain-steps per second and per thread, the
share of contact and of the membrane, the membrane's cost per ball and step) and of writing the
frames. Each run writes into a new folder under --scratch (printed) and touches nothing else.

--cases-from takes the cases of an earlier run of this bench instead of making them: its series,
and its stage outputs linked (make is told not to remake them), so that later stages alone can be
run again on the same grains, e.g. the simulate stage to 18 % at 16 000 grains without the 40
minutes of synth and the CT stages before it. Only micro, simulate, forces, validate and report
can be rerun so; the earlier run's figures of the other stages are published beside the new ones.

    python3 bench/paper_scale.py [--diameters 6 12] [--stages inspect segment contacts shapes track mesh]
        [--simulate-strain 0.18] [--cases-from RUN] [--build build] [--scratch /tmp/graintwin_paper_scale]
        [--conditions TEXT] [--no-publish]
"""
import argparse
import json
import math
import os
import re
import sys
import tempfile
import time
import tomllib

import h5py

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_doc import SOURCE, finish  # noqa: E402
from pipeline_stages_bench import PER_SCAN, run_measured, run_stage  # noqa: E402

SCENE = os.path.join(SOURCE, "pipelines", "scenes", "paper_scale.toml")
TRIAXIAL_SCENE = os.path.join(SOURCE, "pipelines", "scenes", "triaxial.toml")
HEIGHT_OVER_DIAMETER = 25.0 / 12.0
# What each stage that --cases-from can rerun writes in a case's folder (Makefile.pipeline's rules;
# the report also makes the simulation's micro-mechanics).
RERUNNABLE_OUTPUTS = {
    "micro": ["micro.h5", "micro.vtp"],
    "simulate": ["simulation.h5", "simulation_frames"],
    "forces": ["forces.h5", "force_chains"],
    "validate": ["validation.json"],
    "report": ["report.html", "report_img", "simulation_micro.h5"],
}


def folder_bytes(path):
    total = 0
    for root, _, files in os.walk(path):
        for f in files:
            p = os.path.join(root, f)
            if not os.path.islink(p):
                total += os.path.getsize(p)
    return total


def make_series(diameter_mm, solid_fraction, build, folder):
    """ctsynth's paper-scale scene in a cylinder `diameter_mm` across (and at `solid_fraction`,
    unless None): the synth stage's figures."""
    height_mm = diameter_mm * HEIGHT_OVER_DIAMETER
    os.makedirs(os.path.dirname(folder), exist_ok=True)
    cmd = [os.path.join(build, "bin", "ctsynth"), SCENE, folder,
           "--diameter", f"{diameter_mm:g}mm", "--height", f"{height_mm:.4g}mm"]
    if solid_fraction:
        cmd += ["--solid-fraction", f"{solid_fraction:g}"]
    log = folder + ".ctsynth.log"  # beside the series: its status lines tell how a long packing goes
    print(f"ctsynth's log: {log}", flush=True)
    wall, cpu, rss = run_measured(cmd, log=log)
    with open(os.path.join(folder, "series.json")) as f:
        series = json.load(f)
    return {"wall_s": wall, "cpu_s": cpu, "peak_bytes": rss, "output_bytes": folder_bytes(folder),
            "packing_s": series["packing"]["seconds"], "sweeps": series["packing"]["sweeps"],
            "packed_grains": series["grains"], "solid_fraction": series["packing"]["solid_fraction"]}


def packing_text(name, synth):
    """The packing's sweeps and time, and its cost per grain and sweep: a sweep costs the same per
    grain at any size (a cell grid finds the pairs), so the packing grows as N times its sweeps."""
    text = f"{name}: {synth['sweeps']} sweeps in {synth['packing_s']:.0f} s"
    if synth.get("packed_grains"):
        text += f" ({1e6 * synth['packing_s'] / synth['sweeps'] / synth['packed_grains']:.1f} us per grain and sweep)"
    return text


def grains_of(labels_path):
    with h5py.File(labels_path, "r") as f:
        return int(f["grains/label"].shape[0])


def simulate_scene(strain, run_dir):
    """The pipeline's triaxial scene sheared to `strain`, written into the run's folder."""
    path = os.path.join(run_dir, "triaxial.toml")
    text, count = re.subn(r"(?m)^target_axial_strain\s*=.*$", f"target_axial_strain = {strain!r}", open(TRIAXIAL_SCENE).read())
    if count != 1:
        sys.exit(f"paper_scale: {TRIAXIAL_SCENE} has no single target_axial_strain line to change")
    with open(path, "w") as f:
        f.write(text)
    return path


def scene_strain(path):
    with open(path, "rb") as f:
        return tomllib.load(f)["triaxial"]["target_axial_strain"]


def pipeline_scene(series):
    """The triaxial scene Makefile.pipeline's simulate stage picks for `series` (its SIM_SCENE)."""
    own = os.path.join(SOURCE, "pipelines", "scenes", series, "triaxial.toml")
    return own if os.path.exists(own) else TRIAXIAL_SCENE


def link_earlier(earlier, out, stages):
    """Links the earlier case folder's files into `out` (its folders made anew, so that whatever
    make writes lands in `out`, never in the earlier run), but the outputs of `stages` and its logs;
    returns make's -o options for every linked file, so that make never remakes (writes) them."""
    rerun = {entry for stage in stages for entry in RERUNNABLE_OUTPUTS[stage]}
    os.makedirs(os.path.join(out, "logs"))
    keep_old = []
    for entry in sorted(os.listdir(earlier)):
        if entry in rerun or entry == "logs":
            continue
        source = os.path.join(earlier, entry)
        files = [source] if not os.path.isdir(source) else [os.path.join(r, f) for r, _, fs in os.walk(source) for f in fs]
        for f in files:
            linked = os.path.join(out, os.path.relpath(f, earlier))
            os.makedirs(os.path.dirname(linked), exist_ok=True)
            os.symlink(os.path.abspath(f), linked)
            keep_old += ["-o", linked]
    return keep_old


def bench_case(name, inp, stages, build, run_dir, synth=None, earlier=None, scene=None):
    """The case's stages run by make in a new folder; with `earlier`, that folder links an earlier
    run's case outputs, which make keeps as they are."""
    out = os.path.join(run_dir, name)
    os.makedirs(out, exist_ok=True)
    make_options = link_earlier(earlier, out, stages) if earlier else []
    if scene:
        make_options.append(f"SIM_SCENE={scene}")
    rows = {"synth": synth} if synth else {}
    for stage in stages:
        before = folder_bytes(out)
        wall, cpu, rss = run_stage(name, stage, out, build, inp=inp, make_options=make_options)
        rows[stage] = {"wall_s": wall, "cpu_s": cpu, "peak_bytes": rss, "output_bytes": folder_bytes(out) - before}
        print(f"{name:14s} {stage:9s} wall {wall:8.1f} s  cpu {cpu:8.1f} s  peak {rss / 2**30:6.2f} GiB", flush=True)
        if stage == "simulate":
            rows[stage]["accounts"] = simulate_accounts(os.path.join(out, "logs", "fdemrun.log"))
            rows[stage]["axial_strain"] = scene_strain(scene or pipeline_scene(name))
    scans = sorted(d for d in os.listdir(out) if d.startswith("scan_"))
    return {"grains": grains_of(os.path.join(out, scans[0], "labels.h5")), "scans": len(scans), "stages": rows}


def simulate_accounts(log_path):
    """fdemrun's closing accounts ("time: ...", "output: ...") and its membrane size, from its log."""
    accounts = {}
    with open(log_path) as f:
        for line in f:
            for key in ("time", "output", "membrane"):
                marker = f"[info] {key}: "
                # The membrane's size line names its balls; its status lines while consolidating do not.
                if marker in line and (key != "membrane" or " balls of radius " in line):
                    accounts[key] = line.split(marker, 1)[1].strip()
    return accounts


def exponent(a, b, stage):
    """Slope of CPU time against grains: per scan for the stages run once per scan (and synth,
    which renders every scan), per pair of scans for track."""
    ra, rb = a["stages"].get(stage), b["stages"].get(stage)
    if not ra or not rb or ra["cpu_s"] <= 0 or b["grains"] == a["grains"]:
        return None

    def runs(case):
        return case["scans"] if stage in PER_SCAN or stage == "synth" else case["scans"] - 1 if stage == "track" else 1

    return math.log((rb["cpu_s"] / runs(b)) / (ra["cpu_s"] / runs(a))) / math.log(b["grains"] / a["grains"])


def table(results, stages):
    names = list(results)
    head = "| stage | " + " | ".join(f"{n} ({results[n]['grains']} grains, {results[n]['scans']} scans): wall s / CPU s / peak GiB / output MB" for n in names)
    pairs = list(zip(names, names[1:]))
    head += "".join(f" | exponent {a} -> {b}" for a, b in pairs) + " | exponent, smallest -> largest case run |"
    lines = [head, "|---|" + "---|" * (len(names) + len(pairs) + 1)]
    for stage in ["synth"] + stages:
        cells = []
        for n in names:
            r = results[n]["stages"].get(stage)
            cells.append("-" if r is None else
                         f"{r['wall_s']:.1f} / {r['cpu_s']:.1f} / {r['peak_bytes'] / 2**30:.2f} / {r['output_bytes'] / 1e6:.0f}")
        for a, b in pairs:
            e = exponent(results[a], results[b], stage)
            cells.append("-" if e is None else f"{e:.2f}")
        ran = [n for n in names if stage in results[n]["stages"]]  # the cases in grain order
        e = exponent(results[ran[0]], results[ran[-1]], stage) if len(ran) > 1 else None
        cells.append("-" if e is None else f"{e:.2f} ({results[ran[0]]['grains']} -> {results[ran[-1]]['grains']})")
        lines.append(f"| {stage} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def targets_lines(results):
    """The paper-scale targets (2 cores, 16 000 grains), each against the largest case that ran its
    stages: met or by how much missed; a target none of whose cases ran says so."""
    def largest(stages):
        ran = [(n, c) for n, c in results.items() if all(k in c["stages"] for k in stages)]
        return max(ran, key=lambda item: item[1]["grains"]) if ran else (None, None)

    def verdict(seconds, limit_s):
        return "met" if seconds <= limit_s else f"missed by {seconds / limit_s:.2f} x"

    def at(name, case):
        return f"{name}, {case['grains']} grains"

    lines = ["\nTargets at 16 000 grains on 2 cores, each against the largest case that ran it:"]
    name, case = largest(["synth"])
    if case:
        r = case["stages"]["synth"]
        lines.append(f"- ctsynth, three scans, at most 30 min and 12 GB ({at(name, case)}): {r['wall_s'] / 60:.1f} min "
                     f"({verdict(r['wall_s'], 1800)}), {r['peak_bytes'] / 1e9:.1f} GB "
                     f"({'met' if r['peak_bytes'] <= 12e9 else 'missed'}).")
    ct = ["segment", "contacts", "shapes", "track"]
    name, case = largest(ct)
    if case and case["scans"] >= 2:
        st, scans = case["stages"], case["scans"]
        two = sum(st[k]["wall_s"] * 2 / scans for k in ct[:3]) + st["track"]["wall_s"] / (scans - 1)
        peak = max(st[k]["peak_bytes"] for k in ct)
        lines.append(f"- segment, contacts, shapes and track for two scans, at most 5 min and 10 GB ({at(name, case)}): "
                     f"{two / 60:.1f} min (scaled from {scans} scans; {verdict(two, 300)}), {peak / 1e9:.1f} GB "
                     f"({'met' if peak <= 10e9 else 'missed'}).")
    name, case = largest(["mesh"])
    if case:
        wall = case["stages"]["mesh"]["wall_s"]
        lines.append(f"- mesh, at most 20 min ({at(name, case)}): {wall / 60:.1f} min ({verdict(wall, 1200)}).")
    name, case = largest(["simulate"])
    if case:
        r = case["stages"]["simulate"]
        strain = r.get("axial_strain", 0.10)  # runs before the strain was recorded used the pipeline's 10 %
        if strain >= 0.18:
            lines.append(f"- the rigid triaxial test to 18 %, at most 2 h ({at(name, case)}): {r['wall_s'] / 60:.1f} min "
                         f"({verdict(r['wall_s'], 7200)}).")
        else:
            lines.append(f"- the rigid triaxial test to 18 %, at most 2 h ({at(name, case)}): run to {100 * strain:g} % "
                         f"only ({r['wall_s'] / 60:.1f} min).")
    else:
        lines.append("- the rigid triaxial test to 18 % in at most 2 h: not run.")
    after = ["forces", "micro", "report"]
    name, case = largest(after)
    if case:
        together = sum(case["stages"][k]["wall_s"] for k in after)
        lines.append(f"- forces, micro and report, at most 2 min together ({at(name, case)}): {together:.0f} s "
                     f"({verdict(together, 120)}).")
    else:
        lines.append("- forces, micro and report in at most 2 min together: not run.")
    return "\n".join(lines) + "\n"


# The triaxial twin's rate the project aims for at paper scale, membrane included (docs/fdem_triaxial.md).
TARGET_GRAIN_STEPS_PER_CORE = 1e5


def simulate_lines(results):
    """fdemrun's own accounts of each case's simulate stage, as a list."""
    rows = [(n, r["stages"]["simulate"].get("accounts", {})) for n, r in results.items() if "simulate" in r["stages"]]
    if not rows:
        return ""
    text = ("\nThe simulate stage by fdemrun's own accounts (its log's closing lines), its rate per thread against "
            f"the project's target of {TARGET_GRAIN_STEPS_PER_CORE:.0e} grain-steps/s per core:\n")
    for n, acc in rows:
        per_thread = re.search(r"([0-9.e+-]+) per thread", acc.get("time", ""))
        ratio = (f"{float(per_thread.group(1)) / TARGET_GRAIN_STEPS_PER_CORE:.2f} x the target per thread; "
                 if per_thread else "")
        text += f"- {n}: {ratio}{acc.get('time', '?')}; {acc.get('membrane', '')}; writing {acc.get('output', '?')}.\n"
    return text


def merge_results(paths):
    """The cases of several runs' paper_scale.json, ordered by grains: a case in several keeps the
    latest run's stages and the earlier runs' others (e.g. a simulate stage run only once)."""
    merged = {}
    for path in paths:
        with open(path) as f:
            for name, case in json.load(f).items():
                if name in merged:
                    stages = {**merged[name]["stages"], **case["stages"]}
                    merged[name] = {**case, "stages": stages}
                else:
                    merged[name] = case
    return dict(sorted(merged.items(), key=lambda item: item[1]["grains"]))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--diameters", nargs="+", type=float, default=[6.0, 12.0],
                    help="cylinder diameters (mm) of the generated cases; 12 is the experiment's")
    ap.add_argument("--solid-fraction", type=float,
                    help="of the generated cases (default the scene's 0.628, which narrow cylinders cannot reach)")
    ap.add_argument("--stages", nargs="+", default=["inspect", "segment", "contacts", "shapes", "track", "mesh"])
    ap.add_argument("--build", default=os.path.join(SOURCE, "build"))
    ap.add_argument("--scratch", default="/tmp/graintwin_paper_scale")
    ap.add_argument("--no-publish", action="store_true")
    ap.add_argument("--simulate-strain", type=float,
                    help="axial strain the simulate stage shears to (default the pipeline's scene's; 0.18 is the experiment's)")
    ap.add_argument("--cases-from",
                    help="an earlier run's folder of this bench: rerun --stages (micro, simulate, forces, validate, "
                         "report) on its cases, "
                         "publish its figures of the other stages beside them")
    ap.add_argument("--conditions",
                    help="a sentence on what else the machine ran meanwhile, published with the figures")
    ap.add_argument("--results", nargs="+",
                    help="finished runs' paper_scale.json: publish their figures again, run nothing; with several, "
                         "their cases are merged (a later file's stages win, stages it lacks are kept)")
    a = ap.parse_args()
    if a.results and a.cases_from:
        ap.error("--results republishes finished runs and --cases-from runs stages again: give one of them")
    if a.simulate_strain is not None and not 0 < a.simulate_strain < 1:  # NaN fails this too
        ap.error(f"--simulate-strain {a.simulate_strain} is not an axial strain in (0, 1); the experiment's is 0.18")
    build = os.path.abspath(a.build)
    os.makedirs(a.scratch, exist_ok=True)
    run_dir = tempfile.mkdtemp(prefix="paper_scale-", dir=a.scratch)
    print(f"outputs in {run_dir}", flush=True)
    scene = simulate_scene(a.simulate_strain, run_dir) if a.simulate_strain is not None else None
    if a.results:
        results = merge_results(a.results)
        a.stages = [s for s in a.stages if any(s in r["stages"] for r in results.values())]
    elif a.cases_from:
        not_rerunnable = [s for s in a.stages if s not in RERUNNABLE_OUTPUTS]
        if not_rerunnable:
            sys.exit(f"paper_scale: --cases-from reruns only {', '.join(RERUNNABLE_OUTPUTS)}, not {', '.join(not_rerunnable)}; "
                     "run the bench without --cases-from for those")
        try:
            with open(os.path.join(a.cases_from, "paper_scale.json")) as f:
                earlier = json.load(f)
        except OSError as e:
            sys.exit(f"paper_scale: {a.cases_from} is not a finished run of this bench ({e.strerror}); name the folder it printed")
        results = {}
        for name, case in earlier.items():
            if not os.path.isdir(os.path.join(a.cases_from, name)):
                sys.exit(f"paper_scale: {os.path.join(a.cases_from, name)} is missing; --cases-from needs the earlier run's "
                         "folder as it left it")
            series = os.path.join(a.cases_from, "series", name)
            synth = case["stages"].get("synth")
            if synth and "solid_fraction" not in synth and os.path.isdir(series):  # runs before it was recorded
                with open(os.path.join(series, "series.json")) as f:
                    synth["solid_fraction"] = json.load(f)["packing"]["solid_fraction"]
            rerun = bench_case(name, series if os.path.isdir(series) else None, a.stages, build, run_dir,
                               earlier=os.path.join(a.cases_from, name), scene=scene)
            results[name] = {**case, "stages": {**case["stages"], **rerun["stages"]},
                             "rerun": {"stages": a.stages, "date": time.strftime("%Y-%m-%d")}}
    else:
        results = {"sand_small": bench_case("sand_small", None, a.stages, build, run_dir, scene=scene)}
    for d in ([] if a.results or a.cases_from else a.diameters):
        name = f"paper_d{d:g}mm"
        series = os.path.join(run_dir, "series", name)
        synth = make_series(d, a.solid_fraction, build, series)
        print(f"{name:14s} synth     wall {synth['wall_s']:8.1f} s  cpu {synth['cpu_s']:8.1f} s  "
              f"peak {synth['peak_bytes'] / 2**30:6.2f} GiB", flush=True)
        results[name] = bench_case(name, series, a.stages, build, run_dir, synth, scene=scene)
    packing = ", ".join(packing_text(n, r["stages"]["synth"]) for n, r in results.items() if "synth" in r["stages"])
    merged = (f" Figures merged from {len(a.results)} runs of this bench (--results), the latest on the date above; "
              "a stage's row comes from the latest run that ran it." if a.results and len(a.results) > 1 else "")
    reruns = {(tuple(r["rerun"]["stages"]), r["rerun"]["date"]) for r in results.values() if "rerun" in r}
    merged += "".join(f" The stages {', '.join(st)} were run again on {date} on the same cases (--cases-from); the other "
                      "stages' figures are from the run that made them." for st, date in sorted(reruns))
    packed = [f"{n} {r['stages']['synth']['solid_fraction']:.3f}" for n, r in results.items()
              if "solid_fraction" in r["stages"].get("synth", {})]
    solid = (f"packed to solid fraction {', '.join(packed)}" if packed else
             f"at solid fraction {a.solid_fraction or 0.628:g}")
    strains = sorted({r["stages"]["simulate"].get("axial_strain", 0.10) for r in results.values() if "simulate" in r["stages"]})
    sheared = (f" The simulate stage shears the twin to {' and '.join(f'{100 * e:g}' for e in strains)} % axial strain."
               if strains else "")
    text = (
        "Every stage's cost as the sample grows (`python3 bench/paper_scale.py`; "
        f"{os.cpu_count()} cores, {time.strftime('%Y-%m-%d')}). sand_small is the bundled series (its "
        "synth stage is not rerun); the others are pipelines/scenes/paper_scale.toml in a cylinder of the "
        f"named diameter (height 25:12 of it; 12 mm is the experiment's) {solid}, "
        f"three scans each (sand_small has four).{sheared} Per stage: wall "
        "and CPU seconds, the peak resident memory of its largest process and the bytes it wrote; then the "
        "growth exponent of CPU time (per scan for the stages run once per scan and for synth, per pair of scans for "
        "track) against the reference "
        "scan's grains between consecutive cases. "
        f"{f'Packing: {packing}.' if packing else ''}{merged}{f' Conditions: {a.conditions}' if a.conditions else ''}\n\n" + table(results, a.stages) + "\n" + targets_lines(results) + simulate_lines(results))
    finish("paper_scale", text, run_dir, results, not a.no_publish)


if __name__ == "__main__":
    main()
