#!/usr/bin/env python3
"""Damping and selective mass scaling of sand_small's deformable (10-node) twin: the stable step with
mass-proportional damping alone, with stiffness-proportional (Rayleigh) damping, with local
non-viscous damping and with selective mass scaling (its added mass), and how far each settles the
grains: the kinetic / elastic energy ratio over the first steps of the consolidation inside the servo
wall (docs/benchmarks.md, section fdem_deformable_damping; docs/fdemrun.md, damping and selective
mass scaling).

The scene is the pipeline's triaxial test (pipelines/scenes/triaxial.toml) with the model file's own
grain kinds (shapes2mesh's 10-node grains; the smallest grains stay rigid) at the full E = 92.1 GPa.
beta is given as a multiple of the twin's undamped critical element step dt_c, measured first. Each
run reads the model of `make -f Makefile.pipeline SERIES=sand_small mesh` (runs/sand_small/model.h5,
made first when missing) and writes into a new folder under --scratch (printed).

    /usr/bin/python3 bench/fdem_deformable_damping_bench.py [--steps 3000] [--beta-shares 0.75 3]
        [--local 0.7] [--targets 2 4 8] [--jobs 2] [--build build] [--scratch /tmp/graintwin_damping]
        [--no-publish]
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile
import time

import h5py
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_doc import SOURCE, finish  # noqa: E402

SCENE = os.path.join(SOURCE, "pipelines", "scenes", "triaxial.toml")
SERIES = "sand_small"
ELEMENT_SAFETY = 0.8  # fdemrun's default: the element limit is this share of the critical step


def scene_text(run_keys, rigid=False):
    """The pipeline's scene with `run_keys` added to [run]; the model's own grain kinds unless rigid."""
    text = open(SCENE).read()
    if not rigid:
        text, n = re.subn(r'(?m)^kind = "rigid"\n', "", text)
        if n != 1:
            sys.exit(f'{SCENE} has no [model] kind = "rigid" line to drop')
    return text.replace("[run]\n", "[run]\n" + "".join(f"{k} = {v!r}\n" for k, v in run_keys.items()), 1)


def command(build, scene, out, model, steps):
    return [f"{build}/bin/fdemrun", scene, out, "--model", model, "--force", "-j", "1", "--stop-step", str(steps)]


def write_scene(run_dir, name, keys, rigid=False):
    path = os.path.join(run_dir, name + ".toml")
    with open(path, "w") as f:
        f.write(scene_text(keys, rigid))
    return path


def limits(log):
    """The time step and its element and contact limits from fdemrun's log, s."""
    m = re.search(r"time step ([0-9.e+-]+) s \(elements ([0-9.e+-]+|inf) s(?: with stiffness_damping [0-9.e+-]+ s)?, "
                  r"contact ([0-9.e+-]+) s\)", log)
    return {"step": float(m.group(1)), "element_limit": float(m.group(2)), "contact_limit": float(m.group(3))}


def scaling(log):
    """What selective mass scaling did, or the numbers of its refusal, from fdemrun's log."""
    done = re.search(r"selective mass scaling .*?: (\d+) nodes up to ([0-9.e+-]+) times heavier, ([0-9.e+-]+) kg added "
                     r"\(([0-9.e+-]+) % of the grains' mass.*?the unscaled masses guarantee ([0-9.e+-]+) s", log)
    if done:
        return {"nodes": int(done.group(1)), "largest_factor": float(done.group(2)), "added_percent": float(done.group(4)),
                "guaranteed_before": float(done.group(5)), "refused": False}
    refused = re.search(r"would add ([0-9.e+-]+) % of the grains' mass \([0-9.e+-]+ kg on (\d+) nodes, up to "
                        r"([0-9.e+-]+) times heavier\), above the bound of ([0-9.e+-]+) %", log)
    if refused:
        return {"nodes": int(refused.group(2)), "largest_factor": float(refused.group(3)),
                "added_percent": float(refused.group(1)), "refused": True, "message": refused.group(0)}
    return None


def probe(build, run_dir, model, name, keys, rigid=False):
    """fdemrun stopped after its first step: its limits (and scaling), or its refusal."""
    scene = write_scene(run_dir, name, keys, rigid)
    r = subprocess.run(command(build, scene, os.path.join(run_dir, name + ".h5"), model, 1), capture_output=True, text=True)
    with open(os.path.join(run_dir, name + ".log"), "w") as f:
        f.write(r.stderr)
    out = {"name": name, "keys": keys, "scaling": scaling(r.stderr)}
    if r.returncode == 0:
        out.update(limits(r.stderr))
    elif not (out["scaling"] and out["scaling"]["refused"]):
        sys.exit(f"fdemrun {scene} failed:\n{r.stderr[-2000:]}")
    return out


def runaway_step(log_path):
    """The step at which fdemrun stopped a run whose energy ran away (its log's message), else None."""
    m = re.search(r"step (\d+) \(t = [^)]*\): the mechanical energy .* ran away", open(log_path).read())
    return int(m.group(1)) if m else None


def settle_all(build, run_dir, model, cases, steps, jobs):
    """Runs every case for `steps` steps (at most `jobs` at once, one thread each); name -> CPU seconds
    and name -> the step a run that ran away stopped at (fdemrun's runaway stop is a result here; any
    other failure ends the bench)."""
    pending, running, cpu, ran_away = list(cases), {}, {}, {}
    while pending or running:
        while pending and len(running) < jobs:
            name = pending.pop(0)
            scene = write_scene(run_dir, name, cases[name])
            log = open(os.path.join(run_dir, name + ".log"), "w")
            cmd = command(build, scene, os.path.join(run_dir, name + ".h5"), model, steps)
            print("running", " ".join(cmd), flush=True)
            running[subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=log).pid] = name
        pid, status, usage = os.wait4(-1, 0)
        if pid not in running:
            continue
        name = running.pop(pid)
        log_path = os.path.join(run_dir, name + ".log")
        if status != 0:
            step = runaway_step(log_path)
            if step is None:
                sys.exit(f"fdemrun failed on {name}; see {log_path}")
            ran_away[name] = step
        cpu[name] = usage.ru_utime + usage.ru_stime
        print(f"{name}: {cpu[name]:.0f} s CPU" + (f", ran away at step {ran_away[name]}" if name in ran_away else ""), flush=True)
    return cpu, ran_away


def energies(path, steps):
    """The kinetic / elastic ratio and the time at the rows closest to `steps` (a list), and the
    share of the energy put in that was dissipated by the last row."""
    with h5py.File(path, "r") as f:
        s = f["series"]
        step, t = s["step"][:], s["time"][:]
        ratio = s["kinetic"][:] / (s["strain"][:] + s["contact_elastic"][:])
        dissipated = s["dissipated"][:]
    rows = [int(np.argmin(np.abs(step.astype(float) - n))) for n in steps]
    return {"ratio": [float(ratio[r]) for r in rows], "time": [float(t[r]) for r in rows],
            "dissipated": float(dissipated[-1])}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=3000, help="steps of each settling run")
    ap.add_argument("--beta-shares", nargs="+", type=float, default=[0.75, 3.0], help="beta / dt_c of the Rayleigh runs")
    ap.add_argument("--local", type=float, default=0.7, help="local_damping of the local run")
    ap.add_argument("--targets", nargs="+", type=float, default=[1.4, 2.0, 4.0, 8.0],
                    help="selective mass scaling targets, x the undamped element limit (probes at the default bound)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--build", default=os.path.join(SOURCE, "build"))
    ap.add_argument("--scratch", default="/tmp/graintwin_damping")
    ap.add_argument("--no-publish", action="store_true")
    a = ap.parse_args()
    build = os.path.abspath(a.build)
    model = os.path.join(SOURCE, "runs", SERIES, "model.h5")
    if not os.path.exists(model):
        subprocess.run(["make", "-s", "-f", "Makefile.pipeline", f"SERIES={SERIES}", f"BIN={build}/bin", "mesh"], cwd=SOURCE, check=True)
    os.makedirs(a.scratch, exist_ok=True)
    run_dir = tempfile.mkdtemp(prefix="damping-", dir=a.scratch)
    print(f"outputs in {run_dir}", flush=True)

    # The limits: rigid twin, deformable twin undamped, then the dampings and the scaling on it.
    rigid = probe(build, run_dir, model, "rigid", {}, rigid=True)
    plain = probe(build, run_dir, model, "mass_only", {})
    critical = plain["element_limit"] / ELEMENT_SAFETY
    cases = {"mass_only": {}}
    for share in a.beta_shares:
        cases[f"rayleigh_{share:g}"] = {"stiffness_damping": share * critical}
    cases[f"local_{a.local:g}"] = {"local_damping": a.local}
    # Rayleigh with selective mass scaling back to the undamped step, the bound raised to whatever it takes.
    for share in a.beta_shares:
        cases[f"rayleigh_{share:g}_scaled"] = {"stiffness_damping": share * critical, "element_step_target": plain["element_limit"],
                                               "max_added_mass_share": 1.0}
    probes = {"mass_only": plain}
    for name, keys in cases.items():
        if name not in probes:
            probes[name] = probe(build, run_dir, model, name, keys)
        print(name, probes[name], flush=True)
    targets = [probe(build, run_dir, model, f"target_{x:g}", {"element_step_target": x * plain["element_limit"]})
               for x in a.targets]
    for x, t in zip(a.targets, targets):
        print(t, flush=True)
        if not t["scaling"]["refused"]:  # a scaling the bound allows is run too
            cases[t["name"]] = t["keys"]
            probes[t["name"]] = t

    started = time.time()
    cpu, ran_away = settle_all(build, run_dir, model, cases, a.steps, a.jobs)
    marks = [a.steps // 3, 2 * a.steps // 3, a.steps - 1]
    settled = {name: energies(os.path.join(run_dir, name + ".h5"), marks) for name in cases if name not in ran_away}

    lines = ["| run | [run] keys (besides damping = 2000) | step (s) | element limit (s) | contact limit (s) | "
             "added mass | " + " | ".join(f"kinetic / elastic at step {n + 1} (t, us)" for n in marks) + " | CPU s |",
             "|---|---|---|---|---|---|" + "---|" * len(marks) + "---|",
             f"| rigid twin (reference) | model kind = rigid | {rigid['step']:.3g} | - | {rigid['contact_limit']:.3g} | - |" +
             " |" * len(marks) + " |"]
    for name, keys in cases.items():
        p = probes[name]
        sc = p["scaling"]
        added = f"{sc['added_percent']:.3g} % ({sc['nodes']} nodes, up to {sc['largest_factor']:.3g} x)" if sc else "-"
        shown = ", ".join(f"{k} = {v:.3g}" for k, v in keys.items()) or "-"
        if name in ran_away:
            cells = f"**ran away at step {ran_away[name]}** (fdemrun's runaway stop) |" + " |" * (len(marks) - 1)
        else:
            s = settled[name]
            cells = " | ".join(f"{r:.3g} ({1e6 * t:.3g})" for r, t in zip(s["ratio"], s["time"])) + " |"
        lines.append(f"| {name} | {shown} | {p['step']:.3g} | {p['element_limit']:.3g} | {p['contact_limit']:.3g} | {added} | "
                     + cells + f" {cpu[name]:.0f} |")
    target_lines = ["| element_step_target | added mass (share of the grains' mass) | nodes made heavier (largest factor) | at the default bound of 1 % |",
                    "|---|---|---|---|"]
    for x, t in zip(a.targets, targets):
        sc = t["scaling"]
        target_lines.append(f"| {x:g} x the element limit ({x * plain['element_limit']:.3g} s) | {sc['added_percent']:.3g} % | "
                            f"{sc['nodes']} ({sc['largest_factor']:.3g} x) | {'refused' if sc['refused'] else 'runs'} |")
    guaranteed = next((t["scaling"]["guaranteed_before"] for t in targets if not t["scaling"]["refused"]), None)
    text = (f"sand_small's deformable twin (`runs/{SERIES}/model.h5`: shapes2mesh's 10-node grains, the smallest rigid; "
            "E = 92.1 GPa) in the pipeline's triaxial scene with the model's own grain kinds; each run stopped after "
            f"{a.steps} steps of the consolidation inside the servo wall (`/usr/bin/python3 bench/fdem_deformable_damping_bench.py "
            f"{' '.join(sys.argv[1:])}`; one thread per run, {a.jobs} side by side, {os.cpu_count()} cores, {time.strftime('%Y-%m-%d')}; "
            f"settling runs {time.time() - started:.0f} s wall). dt_c = {critical:.3g} s is the twin's undamped critical element "
            "step (the element limit over element_safety 0.8); Rayleigh runs set stiffness_damping = beta as a multiple of it, "
            "the scaled runs lift the element step back to the undamped limit by selective mass scaling (bound raised to 100 %); "
            "target_x runs are scaled to x times the element limit at the default bound and run at that step.\n\n"
            + "\n".join(lines) + "\n\n"
            + ("A run shown as ran away was stopped by fdemrun's runaway check: it was not stable at its step.\n\n"
               if ran_away else "")
            + "Selective mass scaling without damping, asked for multiples of the element limit "
            "(fdemrun stopped after its first step; a refusal gives the same numbers):\n\n" + "\n".join(target_lines) + "\n"
            + (f"\nGershgorin's bound guarantees {guaranteed:.3g} s with the unscaled masses: {guaranteed / plain['element_limit']:.2f} "
               "of the element limit, the estimate k h_min / c x 0.8 that unscaled runs use.\n" if guaranteed else ""))
    finish("fdem_deformable_damping", text, run_dir,
           {"critical": critical, "rigid": rigid, "probes": probes, "targets": targets, "settled": settled, "cpu": cpu,
            "ran_away": ran_away},
           not a.no_publish)


if __name__ == "__main__":
    main()
