#!/usr/bin/python3
"""Reliability harness: hostile inputs, options, resources, outputs, signals and races against all
twelve tools, each case judged by the rules in RULES below; prints per-case results and a summary
and rewrites the `reliability` section of docs/benchmarks.md (cases tried and handled, by kind and
by tool).

It first makes its own small valid inputs in a work folder (a tiny ctsynth series of two scans and
the whole chain on it, about half a minute), then runs every case in a fresh sandbox folder of its
own (the tool's working directory), with its own TMPDIR, a per-case timeout and an address-space
cap. Bad files are made in the sandbox from the valid ones (h5py edits, truncation, byte flips).

usage: bench/reliability.py [--build DIR] [--quick] [--tool NAME] [--kind KIND] [--case TEXT] [--list] [--verbose]
                            [--work DIR] [--keep] [--timeout S] [--memory-gb G] [--no-publish]
  --build DIR    CMake build folder holding bin/<tool> (default: build)
  --quick        a subset (about a tenth of the cases) for a fast check
  --tool NAME    only this tool's cases (repeatable)
  --kind KIND    only cases of this kind (repeatable): valid, input, option, config, resource,
                 output, signal, concurrency
  --case TEXT    only cases whose id holds TEXT (repeatable; the valid runs always run)
  --list         print the cases (id, kind, tool) and exit
  --verbose      print the stderr of every case not handled
  --work DIR     work folder (default: a new temporary folder, removed at the end unless --keep);
                 an existing one with finished inputs is reused
  --timeout S    CPU seconds a case may take before it counts as a hang (default 20; four times
                 that in wall time)
  --memory-gb G  address-space cap of every tool run (default 4)
  --no-publish   do not rewrite docs/benchmarks.md (only a full run, without --quick, --tool or
                 --kind, publishes; a subset never does)
Exit status: 0 when every case tried was handled, 1 when some were not, 3 when the valid inputs
could not be made (then nothing can be judged)."""
import argparse
import dataclasses
import hashlib
import json
import os
import pwd
import re
import resource
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time
from datetime import date
from typing import Callable, Dict, List, Optional

import h5py
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_doc import publish  # noqa: E402

SOURCE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TOOLS = ["volconvert", "volinfo", "ctsynth", "ct2labels", "labels2contacts", "labels2shapes", "shapes2tracks",
         "shapes2mesh", "fdemrun", "tracks2micro", "fdem2forces", "report"]
KINDS = ["valid", "input", "option", "config", "resource", "output", "signal", "concurrency"]
KIND_TEXT = {
    "valid": "valid runs (the baseline: exit 0, exactly the outputs)",
    "input": "input files: missing, empty, truncated, byte-flipped, wrong kind, folder for file, "
             "tables of disagreeing length, NaN/inf values",
    "option": "options: NaN, inf, negative, zero, huge, malformed, unknown, absurd thread counts",
    "config": "config and scene files: misspelt keys, TOML syntax errors, NaN and wrong types",
    "resource": "options that would need absurd memory or time (refused quickly or done within the limits)",
    "output": "outputs: existing without --force, --force onto user folders, output = input, missing folder",
    "signal": "SIGINT, SIGTERM early / mid / late; SIGKILL: children, stale temporaries, the next run",
    "concurrency": "two runs to one output without --force at the same time",
}

RULES = """\
A case is **handled** when all of these hold:
- no crash: the tool was not ended by a signal (other than a SIGKILL the harness sent) and printed
  no sanitizer report;
- no hang: it finished within the per-case timeout of CPU time, summed over its processes ({timeout:g} s,
  or three times the tool's valid run when that is longer; {wall:g} times that in wall time, so a
  busy machine does not make a hang but a deadlock does), under an address-space cap of {memory:g} GB
  (RLIMIT_AS), so absurd memory or time must be refused up front;
- the right exit code: 1 or 2 for bad input (2 where the contract says usage error: an existing
  output without --force, an unknown option, the loser of a race); 0 only where the input is
  legitimately acceptable (such cases accept either a clean refusal or a complete run): every
  numeric option must refuse nan, inf, -inf, a malformed number and 1e308, and may accept -1, 0,
  1e6 and 1e12 when they make sense for it;
- a message: on failure, stderr's first error line starts with the tool's name (`tool: ...`), the
  message names the file or the option at fault, and it prints no number longer than 20 digits;
- no debris: no new or changed file in the case's folder besides the committed outputs (no
  temporaries, no half-written output), nothing left in TMPDIR, no child process still running
  once the tool has exited (after a SIGKILL of the tool: 1 s later);
- inputs unchanged: every input file and every user file has the same checksum before and after;
- signals, sent once the tool catches SIGINT (its handlers are installed after option parsing):
  early (at once), mid and late (at half and four fifths of its valid run's time, if later):
  afterwards either no output exists and the tool said it was interrupted with exit 130, or every
  output exists and the exit is 0, within 5 s of the signal or a quarter of the valid run's time if
  that is longer; SIGINT goes to the process group (as a terminal's Ctrl-C), SIGTERM to the tool
  (as kill);
- SIGKILL mid-run: no child still running 1 s later, and the next run of the same command succeeds
  and leaves no stale temporary of the killed run;
- races: of two runs to the same output without --force, started together, exactly one exits 0 and
  the other 2, and the outputs are the winner's whole set of files.

Unreadable inputs (chmod 000) are tried with the tool run as the user nobody when the harness runs
as root (root reads any file). A signal case whose run ended before the signal is skipped with a
note. A case sees only what these rules see: a run that exits 0 with plausible but wrong numbers
is beyond it."""

# About 60 small sand grains in a 1.4 mm cylinder at 35 um voxels (as tests/ctsynth_test.cpp): two scans
# in a second or two.
SERIES_SCENE = """seed = 5
grain-shape = "sand"
sh-degree = 10
d-min = "0.25mm"
d50 = "0.35mm"
d-max = "0.45mm"
diameter = "1.4mm"
height = "1.6mm"
solid-fraction = 0.45
contact-tolerance = 0.02
voxel-size = "35um"
strains = [0.0, 0.03]
band-width = "0.7mm"
"""

# The FDEM twin of the first scan as rigid grains settling under gravity between the model's platens
# (frame 0 is the initial state, before any contact is computed: fdem2forces starts at frame 1).
# Its grains are 7 to 13 voxels across, and the platens cut the end grains by up to a voxel: 13 %
# of the smallest diameter, so the overlap tolerance is 0.2 instead of 0.1.
FDEM_SCENE = """[run]
duration = {duration}
gravity = [0, 0, -9.81]
damping = 2000
frame_interval = {frame}
series_interval = {series}
overlap_tolerance = 0.2

[model]
kind = "rigid"
"""
FDEM_DURATION = 2e-5

SANITIZER = re.compile(r"AddressSanitizer|LeakSanitizer|UndefinedBehaviorSanitizer|runtime error:|ThreadSanitizer")
NOISE_LINE = re.compile(r"^\S+: \[(info|debug|trace)\]|^Run with --help for more information\.?$")
LONG_NUMBER = re.compile(r"\d{21,}")
NOBODY = "nobody"  # unprivileged user for the unreadable-input cases when the harness is root
STOP_SECONDS, STOP_FRACTION = 5.0, 0.25  # a tool ends within max(5 s, a quarter of its valid run) of a signal
WALL_FACTOR = 4   # a case may take this many times its timeout in wall time (a busy machine), not in CPU time
CLOCK_TICKS = os.sysconf("SC_CLK_TCK")
MAX_LISTED = 60  # cases not handled listed in docs/benchmarks.md


# ------------------------------------------------------------------------------------------------ files

class Digests:
    """sha256 of files, cached under (inode, size, mtime, ctime): any write changes ctime."""

    def __init__(self):
        self.cache = {}

    def of(self, path, st):
        key = (path, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)
        if key not in self.cache:
            h = hashlib.sha256()
            try:
                with open(path, "rb") as f:
                    for block in iter(lambda: f.read(1 << 20), b""):
                        h.update(block)
                self.cache[key] = h.hexdigest()
            except OSError as e:
                self.cache[key] = "unreadable: " + str(e)
        return self.cache[key]


DIGESTS = Digests()


def snapshot(root):
    """Every entry under root: relative path -> ('dir',) | ('link', target) | ('file', size, sha256)."""
    out = {}
    if not os.path.lexists(root):
        return out
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = os.path.join(dirpath, name)
            st = os.lstat(p)
            rel = os.path.relpath(p, root)
            if stat.S_ISDIR(st.st_mode):
                out[rel] = ("dir",)
            elif stat.S_ISLNK(st.st_mode):
                out[rel] = ("link", os.readlink(p))
            else:
                out[rel] = ("file", st.st_size, DIGESTS.of(p, st))
    return out


def under(rel, roots):
    """rel is one of roots or inside one ("." holds everything)."""
    return any(r == "." or rel == r or rel.startswith(r.rstrip("/") + "/") for r in roots)


def copy(src, dst):
    if os.path.isdir(src):
        shutil.copytree(src, dst, symlinks=True)
    else:
        shutil.copyfile(src, dst)
    return dst


def truncate_half(src, dst):
    data = open(src, "rb").read()
    open(dst, "wb").write(data[:len(data) // 2])
    return dst


def flip_bytes(src, dst, where):
    """XOR 0xFF over 16 bytes at each fraction in `where` of the file (0 = just past HDF5's signature)."""
    data = bytearray(open(src, "rb").read())
    for w in where:
        at = 8 if w == 0 else int(len(data) * w)
        for i in range(at, min(at + 16, len(data))):
            data[i] ^= 0xFF
    open(dst, "wb").write(bytes(data))
    return dst


def h5_shrink(path, dataset):
    """Drops the last row of one column of a table, so the table's columns disagree in length."""
    with h5py.File(path, "r+") as f:
        d = f[dataset]
        data, attrs = d[...], dict(d.attrs)
        del f[dataset]
        new = f.create_dataset(dataset, data=data[:-1])
        for k, v in attrs.items():
            new.attrs[k] = v
    return path


def h5_set(path, dataset, value, rows=1):
    """Sets the first `rows` rows of a float dataset to `value` (NaN, inf)."""
    with h5py.File(path, "r+") as f:
        d = f[dataset]
        if d.ndim == 0:
            d[()] = value
        else:
            d[:rows] = value
    return path


def h5_float_volume(path):
    """The scan's voxels as float32 (a legal kind=volume dtype), for NaN voxels."""
    with h5py.File(path, "r+") as f:
        d = f["volume"]
        data, attrs = d[...].astype(np.float32), dict(d.attrs)
        del f["volume"]
        new = f.create_dataset("volume", data=data, chunks=True)
        for k, v in attrs.items():
            new.attrs[k] = v
    return path


# ------------------------------------------------------------------------------------------------ processes

def session_members(sid):
    """Live processes of session `sid` (each tool run starts its own session, its children inherit it)."""
    pids = []
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            s = open(f"/proc/{d}/stat").read()
        except OSError:
            continue
        fields = s[s.rfind(")") + 2:].split()
        if int(fields[3]) == sid and fields[0] not in ("Z", "X"):
            pids.append(int(d))
    return pids


@dataclasses.dataclass
class Run:
    argv: List[str]
    rc: Optional[int] = None          # exit code, or -signal
    seconds: float = 0.0
    cpu: float = 0.0                  # CPU seconds last seen while it ran
    timed_out: bool = False
    out: str = ""
    err: str = ""
    leftovers: List[str] = dataclasses.field(default_factory=list)  # "pid command" still alive after it


class Runner:
    def __init__(self, bin_dir, work, timeout, memory_gb):
        self.bin = bin_dir
        self.work = work
        self.timeout = timeout
        self.memory = int(memory_gb * (1 << 30))
        self.mpl = os.path.join(work, "mplconfig")
        os.makedirs(self.mpl, exist_ok=True)
        os.chmod(self.mpl, 0o777)
        os.chmod(work, 0o755)  # mkdtemp's 0700 would keep an unprivileged run from its inputs

    def start(self, tool, args, cwd, tmpdir, log, unprivileged=False):
        """Starts the tool in its own session; `unprivileged` runs it as nobody when the harness is root
        (root reads any file, so an unreadable input can only be tried that way)."""
        env = dict(os.environ, TMPDIR=tmpdir, NO_COLOR="1", MPLCONFIGDIR=self.mpl)
        who = {}
        if unprivileged and os.geteuid() == 0:
            nobody = pwd.getpwnam(NOBODY)
            who = dict(user=nobody.pw_uid, group=nobody.pw_gid, extra_groups=[])
            for d in (cwd, tmpdir):
                os.chmod(d, 0o777)
        memory = self.memory

        def limits():
            resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
            resource.setrlimit(resource.RLIMIT_CORE, (0, 0))

        out, err = open(log + ".out", "wb"), open(log + ".err", "wb")
        argv = [os.path.join(self.bin, tool)] + args
        p = subprocess.Popen(argv, cwd=cwd, env=env, stdin=subprocess.DEVNULL, stdout=out, stderr=err,
                             start_new_session=True, preexec_fn=limits, **who)
        out.close(), err.close()
        p.graintwin = (argv, log, time.monotonic())
        return p

    def finish(self, p, timeout=None, grace=0.0):
        argv, log, t0 = p.graintwin
        r = Run(argv)
        limit = timeout or self.timeout
        while True:
            try:
                p.wait(timeout=0.05)
                break
            except subprocess.TimeoutExpired:
                pass
            r.cpu = max(r.cpu, cpu_seconds(p.pid))
            if r.cpu > limit or time.monotonic() - t0 > WALL_FACTOR * limit:
                r.timed_out = True
                with_session(p.pid, signal.SIGKILL)
                p.wait()
                break
        r.seconds = time.monotonic() - t0
        r.rc = p.returncode
        r.out = open(log + ".out", errors="replace").read()
        r.err = open(log + ".err", errors="replace").read()
        # after a hang the harness killed the session itself: what is still dying is not a leftover
        members = [] if r.timed_out else session_members(p.pid)
        deadline = time.monotonic() + grace
        while members and time.monotonic() < deadline:
            time.sleep(0.1)
            members = session_members(p.pid)
        for pid in members:
            try:
                cmd = open(f"/proc/{pid}/cmdline", "rb").read().replace(b"\0", b" ").decode(errors="replace")
            except OSError:
                cmd = "?"
            r.leftovers.append(f"{pid} {cmd[:80].strip()}")
        with_session(p.pid, signal.SIGKILL)  # the harness's own children: leave nothing running
        return r

    def run(self, tool, args, cwd, tmpdir, log, timeout=None, unprivileged=False):
        return self.finish(self.start(tool, args, cwd, tmpdir, log, unprivileged), timeout)


def cpu_seconds(sid):
    """CPU time of a tool run: every live process of its session (all threads, and the children each
    has reaped), so gmsh workers and report's chart script count too."""
    total = 0
    for pid in session_members(sid):
        try:
            s = open(f"/proc/{pid}/stat").read()
        except OSError:
            continue
        total += sum(int(x) for x in s[s.rfind(")") + 2:].split()[11:15])
    return total / CLOCK_TICKS


def with_session(sid, sig):
    for pid in session_members(sid):
        try:
            os.kill(pid, sig)
        except ProcessLookupError:
            pass


# ------------------------------------------------------------------------------------------------ inputs

class Inputs:
    """The valid inputs every case starts from, made once with the tools themselves."""

    KIND_OF = {"scan0": "volume", "scan1": "volume", "labels0": "labels", "labels1": "labels",
               "contacts0": "contacts", "contacts1": "contacts", "shapes0": "shapes", "shapes1": "shapes",
               "tracks": "tracks", "model": "fdem_model", "simulation": "fdem_results", "micro": "micro",
               "sim_micro": "micro", "forces": "forces", "volume_big": "volume"}

    def __init__(self, work, runner):
        self.dir = os.path.join(work, "inputs")
        self.runner = runner
        run = os.path.join(self.dir, "run")
        self.p = {
            "scene": os.path.join(self.dir, "scene.toml"),
            "series": os.path.join(self.dir, "series"),
            "series_json": os.path.join(self.dir, "series", "series.json"),
            "scan0": os.path.join(self.dir, "series", "scan_000.h5"),
            "scan1": os.path.join(self.dir, "series", "scan_001.h5"),
            "rundir": run,
            "fdem_scene": os.path.join(self.dir, "fdem_scene.toml"),
            "fdem_scene_long": os.path.join(self.dir, "fdem_scene_long.toml"),
            "raw": os.path.join(self.dir, "big.raw"),
            "volume_big": os.path.join(self.dir, "big.h5"),
        }
        for k in (0, 1):
            for name in ("labels", "contacts", "shapes"):
                self.p[f"{name}{k}"] = os.path.join(run, f"scan_00{k}", f"{name}.h5")
        for name, f in (("tracks", "tracks.h5"), ("model", "model.h5"), ("simulation", "simulation.h5"),
                        ("micro", "micro.h5"), ("sim_micro", "simulation_micro.h5"), ("forces", "forces.h5")):
            self.p[name] = os.path.join(run, f)
        self.done = os.path.join(self.dir, "READY")

    def __getitem__(self, key):
        return self.p[key]

    def make(self):
        if os.path.exists(self.done):
            print(f"reusing the inputs in {self.dir}")
            return True
        shutil.rmtree(self.dir, ignore_errors=True)
        os.makedirs(self.dir)
        t0 = time.monotonic()
        p = self.p
        open(p["scene"], "w").write(SERIES_SCENE)
        open(p["fdem_scene"], "w").write(FDEM_SCENE.format(duration=FDEM_DURATION, frame=FDEM_DURATION / 4,
                                                           series=FDEM_DURATION / 40))
        open(p["fdem_scene_long"], "w").write(FDEM_SCENE.format(duration=10 * FDEM_DURATION, frame=FDEM_DURATION,
                                                                series=FDEM_DURATION / 4))
        # a 160^3 uint16 volume: enough work for volconvert and volinfo to be interrupted mid-run
        rng = np.random.default_rng(1)
        rng.integers(0, 60000, size=(160, 160, 160), dtype=np.uint16).tofile(p["raw"])
        steps = [("ctsynth", [p["scene"], p["series"]])]
        for k in (0, 1):
            d = os.path.join(p["rundir"], f"scan_00{k}")
            os.makedirs(d)
            steps += [("ct2labels", [p[f"scan{k}"], p[f"labels{k}"]]),
                      ("labels2contacts", [p[f"labels{k}"], p[f"scan{k}"], p[f"contacts{k}"]]),
                      ("labels2shapes", [p[f"labels{k}"], p[f"scan{k}"], p[f"shapes{k}"]])]
        steps += [
            ("volconvert", [p["raw"], p["volume_big"], "--dims", "160,160,160", "--dtype", "uint16",
                            "--voxel-size", "20um"]),
            ("shapes2tracks", [p["shapes0"], p["shapes1"], p["tracks"]]),
            ("tracks2micro", [p["tracks"], p["micro"], "--contacts", p["contacts0"], p["contacts1"]]),
            ("shapes2mesh", [p["shapes0"], p["labels0"], p["model"]] + MESH_FAST),
            ("fdemrun", [p["fdem_scene"], p["simulation"], "--model", p["model"]]),
            ("tracks2micro", [p["simulation"], p["sim_micro"]]),
            ("fdem2forces", [p["simulation"], p["forces"], "--from", "1"]),
        ]
        for tool, args in steps:
            t = time.monotonic()
            log = os.path.join(self.dir, f"setup_{tool}")
            r = self.runner.run(tool, args + ["-q"], self.dir, self.dir, log, timeout=300)
            if r.rc != 0:
                print(f"set-up failed: {tool} {' '.join(args)} exited {r.rc}:\n{r.err}")
                return False
            print(f"  set-up {tool:16s} {time.monotonic() - t:6.2f} s")
        open(self.done, "w").write("made in %.1f s\n" % (time.monotonic() - t0))
        print(f"inputs made in {time.monotonic() - t0:.1f} s")
        return True


MESH_FAST = ["--order", "1", "--elements-per-diameter", "3", "--surface-subdivisions", "2"]

# ------------------------------------------------------------------------------------------------ cases


@dataclasses.dataclass
class Case:
    id: str
    tool: str
    kind: str
    args: List[str]                   # "{key}" is an input's path, "@name" a file in the sandbox
    expect: str = "refuse"            # refuse: 1 or 2; usage: 2; ok: 0; either: 0, or 1/2 with a message
    names: List[str] = dataclasses.field(default_factory=list)   # the message names one of these
    outputs: List[str] = dataclasses.field(default_factory=list)  # committed on success (sandbox paths)
    prepare: Optional[Callable] = None  # prepare(sandbox, inputs): makes bad or user files there
    quick: bool = False
    special: Optional[str] = None     # signal / kill / race runners
    params: Dict = dataclasses.field(default_factory=dict)
    std: bool = True                  # append -q and -j 1


def without(argv, options):
    """argv less the given options and each one's value (so a case can set them its own way)."""
    out, skip = [], False
    for a in argv:
        if skip:
            skip = False
        elif a in options:
            skip = True
        else:
            out.append(a)
    return out


def expand(args, inputs, sandbox):
    out = []
    for a in args:
        m = re.fullmatch(r"\{(\w+)\}", a)
        out.append(inputs[m.group(1)] if m else a)
    return out


# What each tool is given: positional arguments (inputs as {key}), its outputs and its input slots
# (argument index or option -> what kind of file it is there).
BASE = {
    "volconvert": (["{scan0}", "out.h5"], ["out.h5"], {0: "volume"}),
    "volinfo": (["{scan0}"], [], {0: "volume"}),
    "ctsynth": (["{scene}", "outdir", "--strains", "0"], ["outdir"], {0: "scene"}),
    "ct2labels": (["{scan0}", "labels.h5"], ["labels.h5"], {0: "volume"}),
    "labels2contacts": (["{labels0}", "{scan0}", "contacts.h5"], ["contacts.h5"], {0: "labels", 1: "volume"}),
    "labels2shapes": (["{labels0}", "{scan0}", "shapes.h5"], ["shapes.h5"], {0: "labels", 1: "volume"}),
    "shapes2tracks": (["{shapes0}", "{shapes1}", "tracks.h5"], ["tracks.h5"], {0: "shapes", 1: "shapes"}),
    "shapes2mesh": (["{shapes0}", "{labels0}", "model.h5"] + MESH_FAST, ["model.h5"], {0: "shapes", 1: "labels"}),
    "fdemrun": (["{fdem_scene}", "results.h5", "--model", "{model}"], ["results.h5"],
                {0: "fdem_scene", 3: "fdem_model"}),
    "tracks2micro": (["{tracks}", "micro.h5", "--contacts", "{contacts0}", "{contacts1}"], ["micro.h5"],
                     {0: "tracks", 3: "contacts"}),
    "fdem2forces": (["{simulation}", "forces.h5", "--from", "1"], ["forces.h5"], {0: "fdem_results"}),
    "report": (["{rundir}", "report.html", "--scan-strains", "{series_json}"], ["report.html", "report_img"],
               {0: "rundir", 3: "series_json"}),
}
# report reads the run folder's files; each can be given by an option too, which is where bad ones go
REPORT_FILE_OPTIONS = {"--tracks": "tracks", "--model": "fdem_model", "--simulation": "fdem_results",
                       "--forces": "forces", "--micro": "micro"}
# Extra outputs the tools write on request (option, sandbox path, is a folder)
OPTIONAL_OUTPUTS = {
    "ct2labels": ("--preview", "preview.png"), "labels2contacts": ("--vtk", "contacts.vtp"),
    "labels2shapes": ("--surfaces", "grains.vtp"), "shapes2tracks": ("--vtk", "tracks.vtp"),
    "shapes2mesh": ("--vtu", "model.vtu"), "fdemrun": ("--vtk", "frames"), "tracks2micro": ("--vtk", "micro.vtp"),
    "fdem2forces": ("--chains", "chains"),
}
# A valid file of each kind and one of another kind (wrong kind)
VALID_OF = {"volume": "scan0", "labels": "labels0", "contacts": "contacts0", "shapes": "shapes0", "tracks": "tracks",
            "fdem_model": "model", "fdem_results": "simulation", "micro": "micro", "forces": "forces"}
WRONG_OF = {"volume": "labels0", "labels": "scan0", "contacts": "labels0", "shapes": "contacts0",
            "tracks": "shapes0", "fdem_model": "shapes0", "fdem_results": "tracks", "micro": "forces",
            "forces": "micro"}
# One column of a table per kind, shortened by a row (its table's columns then disagree)
SHRINK_OF = {"labels": "grains/volume", "contacts": "contacts/pair", "shapes": "grains/volume",
             "tracks": "tracks/centroid", "fdem_model": "element_grain", "fdem_results": "grains/label",
             "micro": "grains/d2min", "forces": "grains/q"}
# Values that are never legitimately NaN or infinite (docs/formats.md), per kind
NONFINITE_OF = {"labels": [("grains/centroid", "nan")], "contacts": [("contacts/normal", "nan")],
                "shapes": [("grains/centroid", "nan"), ("sh/coeffs", "inf")],
                "tracks": [("tracks/centroid", "inf")],  # NaN there means missing
                "fdem_model": [("nodes", "nan"), ("materials/young", "inf")],
                "fdem_results": [("frames/000001/grains/centroid", "nan")], "micro": [("increments/d50", "inf")],
                "forces": [("frames/mean_normal_force", "inf")]}
# For these tools an input of another GrainTwin kind is legitimate
ACCEPTS_ANY_KIND = {"volinfo"}
# Inputs of which the tool reads no floating-point column (tracks2micro takes only the contact pairs)
READS_NO_FLOATS = {("tracks2micro", "contacts")}


def bad_file_cases(tool, argv, outputs, slot, what, quick_first, label=None):
    """Hostile variants of the input at `slot` (argument index) of kind `what`."""
    cases = []
    key = re.fullmatch(r"\{(\w+)\}", argv[slot]).group(1)
    label = label or key

    def case(name, make, expect="refuse", quick=False, ext=".h5"):
        bad = "bad_" + name + ext
        args = list(argv)
        args[slot] = bad

        def prepare(sandbox, inputs, make=make, bad=bad):
            make(inputs[key], os.path.join(sandbox, bad), inputs)
        cases.append(Case(f"{tool}.input.{label}.{name}", tool, "input", args, expect, [bad], outputs, prepare,
                          quick=quick and quick_first))

    ext = ".h5" if what in VALID_OF else (".toml" if what.endswith("scene") else ".json" if what == "series_json" else "")
    args = list(argv)
    args[slot] = "missing" + ext
    cases.append(Case(f"{tool}.input.{label}.missing", tool, "input", args, "refuse", ["missing" + ext], outputs,
                      quick=quick_first))
    args = list(argv)
    args[slot] = "folder" + ext
    cases.append(Case(f"{tool}.input.{label}.folder", tool, "input", args, "refuse", ["folder" + ext], outputs,
                      lambda s, i: os.makedirs(os.path.join(s, "folder" + ext))))

    def unreadable(src, dst, inputs):
        copy(src, dst)
        os.chmod(dst, 0)
    if what == "rundir":
        case("file", lambda s, d, i: open(d, "w").write("a file, not a run folder\n"), ext="", quick=True)
        case("empty_folder", lambda s, d, i: os.makedirs(d), expect="either", ext="")
        return cases
    if what.endswith("scene"):
        if what == "fdem_scene":  # an empty ctsynth scene is legitimate: the defaults' 3 mm sample
            case("empty", lambda s, d, i: open(d, "w").close(), ext=ext)
        case("truncated", lambda s, d, i: open(d, "w").write(open(s).read()[:40] + '\nkey = "unterminated'),
             ext=ext, quick=True)
        case("binary", lambda s, d, i: open(d, "wb").write(b"\x00\xff\xfe garbage \x01\x02\n"), ext=ext)
        case("wrong_kind", lambda s, d, i: copy(i["scan0"], d), ext=ext)
        case("unreadable", unreadable, ext=ext)
        return cases
    if what == "series_json":
        case("empty", lambda s, d, i: open(d, "w").close(), ext=ext, quick=True)
        case("truncated", lambda s, d, i: open(d, "w").write(open(s).read()[:30]), ext=ext)
        case("wrong_structure", lambda s, d, i: open(d, "w").write('{"scans": 5}\n'), ext=ext)
        case("nan_strain", lambda s, d, i: open(d, "w").write(
            json.dumps({"scans": [{"axial_strain": 0.0}, {"axial_strain": float("nan")}]})), ext=ext)
        case("too_few_scans", lambda s, d, i: open(d, "w").write(json.dumps({"scans": [{"axial_strain": 0.0}]})),
             ext=ext)
        return cases
    case("empty", lambda s, d, i: open(d, "w").close(), quick=True)
    case("text", lambda s, d, i: open(d, "w").write("this is not an HDF5 file\n"))
    case("truncated", lambda s, d, i: truncate_half(s, d), quick=True)
    case("flipped_header", lambda s, d, i: flip_bytes(s, d, [0]))
    case("flipped_middle", lambda s, d, i: flip_bytes(s, d, [0.3, 0.5, 0.7]), expect="either")
    case("wrong_kind", lambda s, d, i: copy(i[WRONG_OF[what]], d),
         expect="either" if tool in ACCEPTS_ANY_KIND else "refuse", quick=True)
    case("unreadable", unreadable)
    if what in SHRINK_OF:
        case("table_length", lambda s, d, i: h5_shrink(copy(s, d), SHRINK_OF[what]),
             expect="either" if tool == "volinfo" else "refuse")
    for dataset, value in NONFINITE_OF.get(what, []):
        case(f"{value}_{dataset.replace('/', '_')}",
             lambda s, d, i, ds=dataset, v=value: h5_set(copy(s, d), ds, float(v)),
             expect="either" if tool == "volinfo" or (tool, what) in READS_NO_FLOATS else "refuse")
    if what == "volume":
        case("nan_voxels", lambda s, d, i: h5_set(h5_float_volume(copy(s, d)), "volume", float("nan"), rows=3),
             expect="either" if tool in ("volinfo", "volconvert") else "refuse")
    return cases


def input_cases(tool):
    argv, outputs, slots = BASE[tool]
    cases = []
    for n, (slot, what) in enumerate(slots.items()):
        cases += bad_file_cases(tool, argv, outputs, slot, what, quick_first=n == 0)
    if tool == "report":
        for opt, what in REPORT_FILE_OPTIONS.items():
            argv2 = argv + [opt, "{" + VALID_OF[what] + "}"]
            for c in bad_file_cases(tool, argv2, outputs, len(argv2) - 1, what, False, label=opt[2:] + "_option"):
                name = c.id.split(".")[-1]
                if name in ("missing", "truncated", "wrong_kind", "table_length") or name.startswith(("nan", "inf")):
                    cases.append(c)
    if tool == "volconvert":
        raw = ["{raw}", "out.h5", "--dtype", "uint16", "--voxel-size", "20um"]
        cases += [
            Case("volconvert.input.raw.dims_beyond_file", tool, "input", raw + ["--dims", "161,160,160"], "refuse",
                 ["big.raw", "--dims"], ["out.h5"], quick=True),
            Case("volconvert.input.raw.header_beyond_file", tool, "input",
                 raw + ["--dims", "160,160,160", "--header-bytes", "100000000"], "refuse",
                 ["big.raw", "--header-bytes"], ["out.h5"]),
            Case("volconvert.input.tiff_text", tool, "input", ["bad.tif", "out.h5"], "refuse", ["bad.tif"],
                 ["out.h5"], lambda s, i: open(os.path.join(s, "bad.tif"), "w").write("not a tiff\n")),
            Case("volconvert.input.mhd_bad_header", tool, "input", ["bad.mhd", "out.h5"], "refuse", ["bad.mhd"],
                 ["out.h5"], lambda s, i: open(os.path.join(s, "bad.mhd"), "w").write(
                     "ObjectType = Image\nNDims = 3\nDimSize = 10 10 -5\nElementType = MET_USHORT\n"
                     "ElementDataFile = bad.raw\n")),
            Case("volconvert.input.empty_slice_folder", tool, "input", ["slices", "out.h5"], "refuse", ["slices"],
                 ["out.h5"], lambda s, i: os.makedirs(os.path.join(s, "slices"))),
        ]
    if tool == "shapes2tracks":
        cases.append(Case("shapes2tracks.input.one_scan", tool, "input", ["{shapes0}", "tracks.h5"], "refuse",
                          ["two", "shapes"], ["tracks.h5"], quick=True))
    if tool == "tracks2micro":
        cases.append(Case("tracks2micro.input.contacts_count_mismatch", tool, "input",
                          ["{tracks}", "micro.h5", "--contacts", "{contacts0}"], "refuse", ["--contacts", "contacts"],
                          ["micro.h5"]))
    return cases


OPTION_LINE = re.compile(r"^\s+(?:-\w,)?(--[\w-]+)(?:,--[\w-]+)?(?:\{[^}]*\})?\s+(FLOAT|INT|UINT|TEXT)\S*(\s|$)")
STANDARD_OPTIONS = {"--help", "--version", "--quiet", "--verbose", "--force", "--threads", "--config"}
# Options that take a length with a unit (TEXT in --help); their hostile values get a unit
LENGTH_OPTIONS = {
    "volconvert": ["--voxel-size"], "ct2labels": ["--d50"], "shapes2mesh": ["--membrane-thickness"],
    "ctsynth": ["--d-min", "--d50", "--d-max", "--diameter", "--height", "--voxel-size", "--membrane-thickness",
                "--band-width", "--contact-search"],
}
# Options whose hostile values need a special setting to be read at all (e.g. peaks markers)
OPTION_CONTEXT = {("ct2labels", "--min-distance-vox"): ["--markers", "peaks"],
                  ("ctsynth", "--aspect-ratio"): ["--grain-shape", "ellipsoid"],
                  ("shapes2mesh", "--grains"): ["--packing", "equivalent"],
                  ("shapes2mesh", "--solid-fraction"): ["--packing", "equivalent"],
                  ("shapes2mesh", "--aspect"): ["--packing", "equivalent"],
                  ("shapes2mesh", "--seed"): ["--packing", "equivalent"],
                  ("tracks2micro", "--to"): ["--from", "0"], ("tracks2micro", "--from"): ["--to", "1"]}
# Never a value of any option (1e308 is beyond every physical range and every integer type); the
# others may be legitimate for some options (negative volume-tol: no filter; seed 0; stop-step 1e12)
REFUSED_VALUES = ["nan", "inf", "-inf", "1.5.2", "1e308"]
EITHER_VALUES = ["-1", "0", "1e6", "1e12"]
QUICK_VALUES = {"nan", "1e308"}


def numeric_options(bin_dir, tool):
    """The tool's numeric options from its --help."""
    out = subprocess.run([os.path.join(bin_dir, tool), "--help"], capture_output=True, text=True).stdout
    opts = []
    for line in out.splitlines():
        m = OPTION_LINE.match(line)
        if m and m.group(1) not in STANDARD_OPTIONS and m.group(2) != "TEXT":
            opts.append(m.group(1))
    return opts + LENGTH_OPTIONS.get(tool, [])


def option_cases(tool, options):
    argv, outputs, _ = BASE[tool]
    cases = []
    for i, opt in enumerate(options):
        unit = "mm" if opt in LENGTH_OPTIONS.get(tool, []) else ""
        context = OPTION_CONTEXT.get((tool, opt), [])
        for v in REFUSED_VALUES + EITHER_VALUES:
            value = v + unit if v not in ("nan", "inf", "-inf", "1.5.2") else v  # 1e308mm: a length
            args = without(argv, [opt] + context[::2])
            cases.append(Case(f"{tool}.option.{opt}={value}", tool, "option", args + context + [f"{opt}={value}"],
                              "refuse" if v in REFUSED_VALUES else "either", [opt], outputs,
                              quick=(v in QUICK_VALUES and i % 3 == 0)))
    cases += [
        Case(f"{tool}.option.unknown", tool, "option", argv + ["--no-such-option"], "usage", ["--no-such-option"],
             outputs, quick=True),
        Case(f"{tool}.option.threads=100000", tool, "option", argv + ["-j", "100000"], "either",
             ["--threads", "-j"], outputs, quick=True, std=False),
        Case(f"{tool}.option.threads=-1", tool, "option", argv + ["-j", "-1"], "refuse", ["--threads", "-j"],
             outputs, std=False),
        Case(f"{tool}.option.threads=nan", tool, "option", argv + ["-j", "nan"], "refuse", ["--threads", "-j"],
             outputs, std=False),
    ]
    if options:  # the option last, so nothing after it can be taken for its value
        cases.append(Case(f"{tool}.option.missing_value", tool, "option", argv + ["-q", "-j", "1", options[0]], "usage",
                          [options[0]], outputs, std=False))
    return cases


def config_cases(tool, options):
    argv, outputs, _ = BASE[tool]
    cases = []
    # a key the command line does not set as well (the command line wins over the config file)
    first = next((o for o in options if o not in argv), None)

    def cfg(name, text, names, expect="refuse", quick=False):
        path = f"cfg_{name}.toml"
        cases.append(Case(f"{tool}.config.{name}", tool, "config", argv + ["--config", path], expect, names,
                          outputs, lambda s, i, t=text, p=path: open(os.path.join(s, p), "w").write(t), quick=quick))
    if tool == "ctsynth":
        scene = SERIES_SCENE.replace("strains = [0.0, 0.03]", "strains = [0.0]")

        def sc(name, text, names, expect="refuse", quick=False):
            path = f"scene_{name}.toml"
            args = [path] + argv[1:]
            cases.append(Case(f"{tool}.config.scene_{name}", tool, "config", args, expect, names, outputs,
                              lambda s, i, t=text, p=path: open(os.path.join(s, p), "w").write(t), quick=quick))
        sc("misspelt_key", scene + "blurr = 0.8\n", ["blurr"], quick=True)
        sc("syntax_error", scene + "blur = = 0.8\n", ["scene_syntax_error.toml"])
        sc("nan_value", scene + "blur = nan\n", ["blur"])
        sc("string_for_number", scene + 'blur = "lots"\n', ["blur"])
        sc("duplicate_key", scene + "seed = 6\n", ["seed", "scene_duplicate_key.toml"])
        sc("array_for_number", scene + "noise = [0.1, 0.2]\n", ["noise"])
        return cases
    if tool == "fdemrun":
        base = FDEM_SCENE.format(duration=FDEM_DURATION, frame=FDEM_DURATION / 4, series=FDEM_DURATION / 40)

        def sc(name, text, names, expect="refuse", quick=False, kind="config"):
            path = f"scene_{name}.toml"
            args = [path] + argv[1:]
            cases.append(Case(f"{tool}.{kind}.scene_{name}", tool, kind, args, expect, names, outputs,
                              lambda s, i, t=text, p=path: open(os.path.join(s, p), "w").write(t), quick=quick))
        sc("misspelt_key", base.replace("damping", "dampnig"), ["dampnig"], quick=True)
        sc("unknown_table", base + "[runn]\nduration = 1\n", ["runn"])
        sc("syntax_error", base + "[[materials]\n", ["scene_syntax_error.toml"])
        sc("nan_duration", base.replace(f"duration = {FDEM_DURATION}", "duration = nan"), ["duration"])
        sc("inf_gravity", base.replace("gravity = [0, 0, -9.81]", "gravity = [0, 0, -inf]"), ["gravity"])
        sc("negative_damping", base.replace("damping = 2000", "damping = -5"), ["damping"])
        sc("string_for_number", base.replace("damping = 2000", 'damping = "high"'), ["damping"])
        sc("zero_young", base + '[[materials]]\nname = "ottawa_sand"\nyoung = 0\n', ["young"])
        sc("negative_density", base + '[[materials]]\nname = "ottawa_sand"\ndensity = -2650\n', ["density"])
        sc("nan_friction", base + '[[materials]]\nname = "ottawa_sand"\nfriction = nan\n', ["friction"])
        sc("box_without_size", base + '[[grains]]\nshape = "box"\nposition = [0, 0, 0.01]\n', ["size"])
        sc("huge_penalty", base + '[[materials]]\nname = "ottawa_sand"\nnormal_penalty = 1e30\n'
           'tangential_penalty = 1e30\n', ["penalty", "step"], kind="resource")
        sc("long_duration", base.replace(f"duration = {FDEM_DURATION}", "duration = 1e3"), ["duration", "step"],
           kind="resource", quick=True)
        sc("tiny_time_step", base.replace("[run]\n", "[run]\ntime_step = 1e-30\n"), ["time_step", "step"],
           kind="resource")
        sc("overlapping_boxes", base + '[[grains]]\nshape = "box"\nsize = [1e-3, 1e-3, 1e-3]\n'
           'position = [0, 0, 0.02]\nkind = "rigid"\n[[grains]]\nshape = "box"\nsize = [1e-3, 1e-3, 1e-3]\n'
           'position = [0.0005, 0, 0.02]\nkind = "rigid"\n', ["overlap"])
    if first is None:
        return cases
    key = first[2:]
    cfg("misspelt_key", f"{key}x = 1\n", [key + "x"], quick=True)
    cfg("syntax_error", f"{key} = = 1\n", ["cfg_syntax_error.toml"])
    cfg("nan_value", f"{key} = nan\n", [key])
    cfg("string_for_number", f'{key} = "lots"\n', [key])
    cfg("threads_huge", "threads = 100000\n", ["threads"], expect="either")
    cases.append(Case(f"{tool}.config.missing_file", tool, "config", argv + ["--config", "nothere.toml"], "refuse",
                      ["nothere.toml"], outputs))
    cases.append(Case(f"{tool}.config.folder", tool, "config", argv + ["--config", "cfgdir"], "refuse", ["cfgdir"],
                      outputs, lambda s, i: os.makedirs(os.path.join(s, "cfgdir"))))
    return cases


def resource_cases(tool):
    argv, outputs, _ = BASE[tool]
    R = []

    def rc(name, extra, names, expect="refuse", quick=False, args=None):
        R.append(Case(f"{tool}.resource.{name}", tool, "resource", without(args or argv, extra[::2]) + extra, expect,
                      names, outputs, quick=quick))
    if tool == "volconvert":
        raw = ["{raw}", "out.h5", "--dtype", "uint16", "--voxel-size", "20um"]
        rc("dims_overflow_crop", ["--dims", "128,144115188075856997,1", "--crop", "0:2,0:1000,:"],
           ["--dims", "big.raw"], args=raw, quick=True)
        rc("dims_overflow", ["--dims", "128,144115188075856997,1"], ["--dims", "big.raw"], args=raw)
        rc("dims_huge", ["--dims", "100000,100000,100000"], ["--dims", "big.raw"], args=raw)
        rc("downsample_huge", ["--downsample", "1000000"], ["--downsample"], expect="either")
    if tool == "ctsynth":
        rc("blur_huge", ["--blur", "1e6"], ["--blur"], quick=True)
        rc("diameter_10m", ["--diameter", "10m"], ["--diameter"])
        rc("voxel_1nm", ["--voxel-size", "1e-9"], ["--voxel-size"])
        rc("margin_huge", ["--margin-vox", "1e9"], ["--margin-vox"])
        rc("grey_scale_saturates", ["--grey-scale", "1e12"], ["--grey-scale"])
        rc("psd_tiny_grains", ["--d-min", "1um", "--d50", "2um", "--d-max", "3um"], ["--d-min", "--d50"])
        rc("supersample_16", ["--supersample", "16"], ["--supersample"], expect="either")
    if tool == "ct2labels":
        rc("sigma_huge", ["--sigma-vox", "1e6"], ["--sigma-vox"], quick=True)
        rc("open_huge", ["--open-vox", "1e6"], ["--open-vox"])
        rc("min_distance_huge", ["--markers", "peaks", "--min-distance-vox", "1e9"], ["--min-distance-vox"],
           expect="either")
    if tool == "labels2contacts":
        rc("window_huge", ["--window-vox", "1e6"], ["--window-vox"], quick=True)
        rc("bins_huge", ["--theta-bins", "1000000000", "--phi-bins", "1000000000"], ["--theta-bins", "--phi-bins"])
    if tool == "labels2shapes":
        rc("directions_1e9", ["--directions", "1000000000"], ["--directions"], quick=True)
        rc("directions_1e6_degree_40", ["--degree", "40", "--directions", "1000000"], ["--directions", "--degree"])
    if tool == "shapes2tracks":
        rc("window_huge", ["--window", "1e9", "--method", "paper"], ["--window"], expect="either")
        rc("local_radius_huge", ["--local-radius", "1e9"], ["--local-radius"], expect="either")
    if tool == "shapes2mesh":
        rc("elements_per_diameter_100", ["--elements-per-diameter", "100"], ["--elements-per-diameter"],
           quick=True)
        rc("surface_nodes_max", ["--surface-nodes", "100000"], ["--surface-nodes"], expect="either")
        rc("equivalent_grains_huge", ["--packing", "equivalent", "--grains", "1000000000"], ["--grains"])
    if tool == "tracks2micro":
        rc("rdf_huge", ["--rdf-max-d50", "1e9", "--rdf-bins", "100000"], ["--rdf-max-d50"], expect="either")
        rc("radius_huge", ["--radius-d50", "1e9"], ["--radius-d50"], expect="either")
    if tool == "fdem2forces":
        rc("window_huge", ["--window", "1000000000"], ["--window"], expect="either")
        rc("radius_huge", ["--radius-d50", "1e9"], ["--radius-d50"], expect="either")
    if tool == "report":
        rc("max_series_huge", ["--max-series", "1000000"], ["--max-series"])
    if tool == "volinfo":
        rc("big_volume_range", [], [], expect="ok", args=["{volume_big}"])
    if tool == "fdemrun":
        rc("stop_step_huge", ["--stop-step", "1000000000000"], ["--stop-step"], expect="either")
    return R


def output_cases(tool):
    argv, outputs, _ = BASE[tool]
    if not outputs:
        return []
    main = outputs[0]
    idx = argv.index(main)
    C = []

    def with_output(path):
        a = list(argv)
        a[idx] = path
        return a

    def user_file(name, text="user data\n"):
        def prepare(s, i):
            p = os.path.join(s, name)
            os.makedirs(os.path.dirname(p), exist_ok=True)
            open(p, "w").write(text)
        return prepare

    def user_folder(name):
        def prepare(s, i):
            os.makedirs(os.path.join(s, name))
            open(os.path.join(s, name, "keep.txt"), "w").write("a user's file\n")
        return prepare

    def canary(s, i):
        open(os.path.join(s, "canary.txt"), "w").write("a user's file beside the outputs\n")

    C.append(Case(f"{tool}.output.exists", tool, "output", argv, "usage", [main], outputs,
                  user_file(main) if main != "outdir" else user_folder(main), quick=True))
    C.append(Case(f"{tool}.output.force_dot", tool, "output", with_output(".") + ["--force"], "either", ["."],
                  ["."] if tool == "ctsynth" else [], canary))
    C.append(Case(f"{tool}.output.force_user_folder", tool, "output", with_output("userdir") + ["--force"],
                  "either", ["userdir"], ["userdir"], user_folder("userdir"), quick=True))
    C.append(Case(f"{tool}.output.missing_folder", tool, "output", with_output("nofolder/" + main), "refuse",
                  ["nofolder"], ["nofolder"], quick=True))
    C.append(Case(f"{tool}.output.file_as_folder", tool, "output", with_output("afile/" + main), "refuse",
                  ["afile"], [], user_file("afile")))
    # the output is one of the inputs: the input copied into the sandbox and named twice
    _, _, slots = BASE[tool]
    slot = next(iter(slots))
    key = re.fullmatch(r"\{(\w+)\}", argv[slot]).group(1)
    if tool not in ("ctsynth", "report", "fdemrun"):
        for name, out in (("same_path", "in.h5"), ("same_file_other_spelling", "./sub/../in.h5"),
                          ("same_file_hardlink", "link.h5")):
            a = list(argv)
            a[slot] = "in.h5"
            a[idx] = out

            def prepare(s, i, key=key):
                copy(i[key], os.path.join(s, "in.h5"))
                os.makedirs(os.path.join(s, "sub"))
                os.link(os.path.join(s, "in.h5"), os.path.join(s, "link.h5"))
            C.append(Case(f"{tool}.output.{name}", tool, "output", a + ["--force"], "refuse", ["in.h5", "link.h5"],
                          [], prepare, quick=name == "same_path"))
    if tool == "fdemrun":
        C.append(Case("fdemrun.output.same_as_model", tool, "output",
                      ["{fdem_scene}", "model.h5", "--model", "model.h5", "--force"], "refuse", ["model.h5"], [],
                      lambda s, i: copy(i["model"], os.path.join(s, "model.h5")), quick=True))
    if tool == "report":
        C.append(Case("report.output.inside_rundir_img_user_folder", tool, "output",
                      ["run", "run/report.html", "--force"], "either", ["report_img"],
                      ["run/report.html", "run/report_img"],
                      lambda s, i: (copy(i["rundir"], os.path.join(s, "run")),
                                    user_folder("run/report_img")(s, i))))
    if tool == "ctsynth":
        C.append(Case("ctsynth.output.outdir_is_scene_folder", tool, "output",
                      ["scenes/scene.toml", "scenes", "--strains", "0", "--force"], "either", ["scenes"], ["scenes"],
                      lambda s, i: (os.makedirs(os.path.join(s, "scenes")),
                                    copy(i["scene"], os.path.join(s, "scenes", "scene.toml")))))
    if tool in OPTIONAL_OUTPUTS:
        opt, path = OPTIONAL_OUTPUTS[tool]
        C.append(Case(f"{tool}.output.extra_exists", tool, "output", argv + [opt, path], "usage", [path],
                      outputs + [path], user_file(path)))
        C.append(Case(f"{tool}.output.extra_missing_folder", tool, "output", argv + [opt, "nofolder/" + path],
                      "refuse", ["nofolder"], outputs + ["nofolder"]))
        C.append(Case(f"{tool}.output.extra_user_folder", tool, "output", argv + [opt, "userdir", "--force"],
                      "either", ["userdir"], outputs + ["userdir"], user_folder("userdir")))
        C.append(Case(f"{tool}.output.extra_same_as_main", tool, "output", argv + [opt, main], "refuse",
                      [main, opt], outputs))
    return C


# Tools that have some work to interrupt: the base invocation, or a longer one
LONG = {
    "volconvert": (["{raw}", "out.h5", "--dims", "160,160,160", "--dtype", "uint16", "--voxel-size", "20um"],
                   ["out.h5"]),
    "volinfo": (["{volume_big}"], []),
    "fdemrun": (["{fdem_scene_long}", "results.h5", "--model", "{model}", "--vtk", "frames"], ["results.h5", "frames"]),
    "shapes2mesh": (["{shapes0}", "{labels0}", "model.h5", "--vtu", "model.vtu", "--msh", "model.msh", "-j", "2"] + MESH_FAST,
                    ["model.h5", "model.vtu", "model.msh"]),
    "ctsynth": (["{scene}", "outdir"], ["outdir"]),
}


def long_invocation(tool):
    if tool in LONG:
        return LONG[tool]
    argv, outputs, _ = BASE[tool]
    if tool in OPTIONAL_OUTPUTS:
        opt, path = OPTIONAL_OUTPUTS[tool]
        return argv + [opt, path], outputs + [path]
    return argv, outputs


def valid_cases(tool):
    argv, outputs = long_invocation(tool)
    return [Case(f"{tool}.valid.run", tool, "valid", argv, "ok", [], outputs, quick=True,
                 std="-j" not in argv)]


def signal_cases(tool):
    argv, outputs = long_invocation(tool)
    std = "-j" not in argv
    C = []
    for sig in ("SIGINT", "SIGTERM"):
        for moment, fraction in (("early", 0.0), ("mid", 0.5), ("late", 0.8)):
            C.append(Case(f"{tool}.signal.{sig}_{moment}", tool, "signal", argv, "interrupted",
                          ["interrupt"], outputs, special="signal", std=std,
                          params={"signal": sig, "fraction": fraction}, quick=(sig == "SIGINT" and moment == "mid")))
    C.append(Case(f"{tool}.signal.SIGKILL_mid", tool, "signal", argv, "killed", [], outputs, special="kill", std=std,
                  params={"fraction": 0.5}, quick=True))
    return C


RACE = {
    "ct2labels": (["{scan0}", "labels.h5"], ["labels.h5"], [["--sigma-vox", "0.4"], ["--sigma-vox", "0.5"]]),
    "labels2shapes": (["{labels0}", "{scan0}", "shapes.h5", "--surfaces", "grains.vtp"], ["shapes.h5", "grains.vtp"],
                      [["--degree", "8"], ["--degree", "10"]]),
    "ctsynth": (["{scene}", "outdir", "--strains", "0"], ["outdir"], [["--seed", "1"], ["--seed", "2"]]),
    "fdemrun": (["{fdem_scene}", "results.h5", "--model", "{model}"], ["results.h5"],
                [["--stop-step", "0"], ["--stop-step", "1000000"]]),
    "volconvert": (["{scan0}", "out.h5"], ["out.h5"], [["--downsample", "1"], ["--downsample", "2"]]),
    "report": (["{rundir}", "report.html", "--scan-strains", "{series_json}"], ["report.html", "report_img"],
               [["--max-series", "2", "--title", "run A"], ["--max-series", "4", "--title", "run B"]]),
}


def concurrency_cases(tool):
    if tool not in RACE:
        return []
    argv, outputs, variants = RACE[tool]
    return [Case(f"{tool}.concurrency.two_runs_one_output", tool, "concurrency", argv, "race", outputs,
                 outputs, special="race", params={"variants": variants}, quick=tool in ("ct2labels", "report"))]


def all_cases(bin_dir, tools, kinds):
    cases = []
    for tool in tools:
        options = numeric_options(bin_dir, tool)
        cases += (valid_cases(tool) + input_cases(tool) + option_cases(tool, options) + config_cases(tool, options)
                  + resource_cases(tool) + output_cases(tool) + signal_cases(tool) + concurrency_cases(tool))
    cases = [c for c in cases if c.kind in kinds]
    ids = set()
    for c in cases:
        assert c.id not in ids, c.id
        ids.add(c.id)
    return cases


# ------------------------------------------------------------------------------------------------ judging

def error_lines(err):
    return [ln for ln in err.splitlines() if ln.strip() and not NOISE_LINE.search(ln.strip())]


def judge_message(case, r, problems):
    lines = error_lines(r.err)
    if not lines:
        problems.append("no error message on stderr")
        return
    if not lines[0].startswith(case.tool + ":"):
        problems.append(f"message not prefixed with '{case.tool}:': {lines[0][:100]!r}")
    text = "\n".join(lines)
    if case.names and not any(n in text or n.lstrip("-") in text for n in case.names):
        problems.append(f"message names none of {case.names}: {lines[-1][:140]!r}")
    if LONG_NUMBER.search(text):
        problems.append("message prints a number of more than 20 digits")


def judge_files(case, before, after, outputs_allowed, problems, inputs_before, inputs_after):
    if inputs_before != inputs_after:
        changed = sorted(k for k in set(inputs_before) | set(inputs_after) if inputs_before.get(k) != inputs_after.get(k))
        problems.append(f"input files changed: {changed[:5]}")
    """A file that was there before may change only when it is itself a committed output (replaced with
    --force), never when it lies inside an output folder (a user's folder named as the output); new
    entries may appear only at or inside the committed outputs."""
    for rel in sorted(set(before) | set(after)):
        if before.get(rel) == after.get(rel):
            continue
        if rel in before and rel in outputs_allowed and before[rel][0] != "dir":
            continue
        if rel in before and before[rel][0] == "dir" and rel in after:
            continue
        if rel not in before and under(rel, outputs_allowed):
            continue
        if rel in before and rel not in after:
            problems.append(f"user file deleted: {rel}")
        elif rel in before:
            problems.append(f"user file changed: {rel}")
        else:
            problems.append(f"left behind: {rel}")
        if len(problems) > 8:
            break


def judge_run(case, r, problems, expect_codes):
    if r.timed_out:
        problems.append(f"hang: unfinished after {r.cpu:.0f} s of CPU time ({r.seconds:.0f} s wall)")
    elif r.rc < 0:
        problems.append(f"crash: ended by {signal.Signals(-r.rc).name}")
    elif r.rc not in expect_codes:
        problems.append(f"exit {r.rc}, expected {'/'.join(map(str, sorted(expect_codes)))}")
    if SANITIZER.search(r.err):
        problems.append("sanitizer report")
    if r.leftovers:
        problems.append(f"child processes still running: {r.leftovers[:3]}")


EXPECT_CODES = {"refuse": {1, 2}, "usage": {2}, "ok": {0}, "either": {0, 1, 2}}


@dataclasses.dataclass
class Result:
    case: Case
    handled: Optional[bool]           # None: skipped
    problems: List[str]
    seconds: float
    err: str = ""
    note: str = ""


class Harness:
    def __init__(self, runner, inputs, work, keep):
        self.runner = runner
        self.inputs = inputs
        self.work = work
        self.keep = keep
        self.counter = 0
        self.baseline = {}  # tool -> seconds of its valid (long) run

    def sandbox(self, case):
        self.counter += 1
        base = os.path.join(self.work, "cases", f"{self.counter:04d}_{re.sub(r'[^A-Za-z0-9_.=-]', '_', case.id)[:80]}")
        box, tmp, logs = os.path.join(base, "box"), os.path.join(base, "tmp"), os.path.join(base, "logs")
        for d in (box, tmp, logs):
            os.makedirs(d)
        return base, box, tmp, logs

    def args(self, case, argv=None):
        a = expand(argv if argv is not None else case.args, self.inputs, None)
        return a + (["-q", "-j", "1"] if case.std else [])

    def run_case(self, case):
        base, box, tmp, logs = self.sandbox(case)
        if case.prepare:
            try:
                case.prepare(box, self.inputs)
            except (OSError, KeyError, ValueError) as e:  # e.g. a dataset the inputs no longer have
                return Result(case, None, [], 0.0, note=f"could not make the case's files: {e!r}")
        inputs_before = snapshot(self.inputs.dir)
        before = snapshot(box)
        special = {"signal": self.signal_case, "kill": self.kill_case, "race": self.race_case}.get(case.special)
        if special:
            res = special(case, box, tmp, logs, before, inputs_before)
        else:
            r = self.runner.run(case.tool, self.args(case), box, tmp, os.path.join(logs, "run"), self.timeout(case),
                                unprivileged=case.id.endswith(".unreadable"))
            problems = []
            judge_run(case, r, problems, EXPECT_CODES[case.expect])
            if not r.timed_out and r.rc is not None and r.rc > 0:
                judge_message(case, r, problems)
            if r.rc == 0:
                for o in case.outputs:
                    if o != "." and not os.path.exists(os.path.join(box, o)):
                        problems.append(f"exit 0 but output {o} missing")
            # after a hang the harness killed the tool: its temporaries are the kill's, not a finding
            allowed = case.outputs if r.rc == 0 else ["."] if r.timed_out else []
            judge_files(case, before, snapshot(box), allowed, problems, inputs_before, snapshot(self.inputs.dir))
            self.check_tmp(tmp, problems)
            if case.kind == "valid" and r.rc == 0:
                self.baseline[case.tool] = r.seconds
            res = Result(case, not problems, problems, r.seconds, r.err)
        if res.handled is not False and not self.keep:
            shutil.rmtree(base, ignore_errors=True)
        return res

    def timeout(self, case):
        """The per-case timeout, or three times the tool's valid run when that is longer (report draws
        its charts in Python for several seconds; the machine may be busy)."""
        return max(self.runner.timeout, 3 * self.baseline.get(case.tool, 0.0))

    @staticmethod
    def check_tmp(tmp, problems):
        left = os.listdir(tmp)
        if left:
            problems.append(f"left in TMPDIR: {sorted(left)[:3]}")

    def moment(self, case):
        base = self.baseline.get(case.tool)
        if base is None:
            return None
        return case.params["fraction"] * base

    @staticmethod
    def wait_for(p, at):
        """Waits until the tool catches SIGINT (its handlers are installed once its options are parsed;
        before that the default action ends any program, which no tool can change), then until `at` s
        after its start."""
        t0 = p.graintwin[2]
        while p.poll() is None and time.monotonic() - t0 < at + 10.0:
            try:
                caught = next(ln for ln in open(f"/proc/{p.pid}/status") if ln.startswith("SigCgt:"))
            except (OSError, StopIteration):
                break
            if int(caught.split()[1], 16) & (1 << (signal.SIGINT - 1)):
                break
            time.sleep(0.002)
        time.sleep(max(0.0, at - (time.monotonic() - t0)))

    def signal_case(self, case, box, tmp, logs, before, inputs_before):
        at = self.moment(case)
        if at is None:
            return Result(case, None, [], 0.0, note="no baseline: the valid run of this tool failed or was not run")
        sig = getattr(signal, case.params["signal"])
        p = self.runner.start(case.tool, self.args(case), box, tmp, os.path.join(logs, "run"))
        self.wait_for(p, at)
        at = time.monotonic() - p.graintwin[2]
        if p.poll() is not None:
            r = self.runner.finish(p)
            return Result(case, None, [], r.seconds, note=f"finished in {r.seconds:.2f} s, before the signal at {at:.2f} s")
        # SIGINT as a terminal sends it (to the process group), SIGTERM as kill sends it (to the process)
        if sig == signal.SIGINT:
            os.killpg(p.pid, sig)
        else:
            os.kill(p.pid, sig)
        r = self.runner.finish(p, self.timeout(case))
        problems = []
        judge_run(case, r, problems, {0, 130})
        allowed = max(STOP_SECONDS, STOP_FRACTION * self.baseline[case.tool])
        if not r.timed_out and r.seconds - at > allowed:
            problems.append(f"took {r.seconds - at:.1f} s to end after {case.params['signal']} "
                            f"(at most {allowed:.1f} s)")
        after = snapshot(box)
        if r.rc == 130:
            if not any("interrupt" in ln for ln in error_lines(r.err)):
                problems.append("exit 130 without saying it was interrupted")
            judge_files(case, before, after, [], problems, inputs_before, snapshot(self.inputs.dir))
        elif r.rc == 0:
            for o in case.outputs:
                if not os.path.exists(os.path.join(box, o)):
                    problems.append(f"exit 0 after the signal but output {o} missing")
            judge_files(case, before, after, case.outputs, problems, inputs_before, snapshot(self.inputs.dir))
        self.check_tmp(tmp, problems)
        return Result(case, not problems, problems, r.seconds, r.err, note=f"signal at {at:.2f} s")

    def kill_case(self, case, box, tmp, logs, before, inputs_before):
        at = self.moment(case)
        if at is None:
            return Result(case, None, [], 0.0, note="no baseline: the valid run of this tool failed or was not run")
        p = self.runner.start(case.tool, self.args(case), box, tmp, os.path.join(logs, "run"))
        self.wait_for(p, at)
        if p.poll() is not None:
            r = self.runner.finish(p)
            return Result(case, None, [], r.seconds, note=f"finished in {r.seconds:.2f} s, before SIGKILL at {at:.2f} s")
        os.kill(p.pid, signal.SIGKILL)
        r = self.runner.finish(p, grace=1.0)
        problems = []
        if r.leftovers:
            problems.append(f"child processes still running 1 s after SIGKILL of {case.tool}: {r.leftovers[:3]}")
        after = snapshot(box)
        partial = [o for o in case.outputs if o in after]
        if partial and len(partial) < len(case.outputs):
            problems.append(f"a partial set of outputs after SIGKILL: {partial}")
        stale = sorted(k for k in after if k not in before and not under(k, case.outputs))
        # the next run of the same command (with --force should the killed run have finished its outputs)
        again = self.args(case) + (["--force"] if partial else [])
        r2 = self.runner.run(case.tool, again, box, tmp, os.path.join(logs, "next"), self.timeout(case))
        if r2.rc != 0:
            problems.append(f"the next run exited {r2.rc}: {error_lines(r2.err)[-1:]}")
        after2 = snapshot(box)
        left = sorted(k for k in after2 if k not in before and not under(k, case.outputs))
        if left:
            problems.append(f"stale temporaries of the killed run not cleared by the next run: {left[:3]}")
        if snapshot(self.inputs.dir) != inputs_before:
            problems.append("input files changed")
        self.check_tmp(tmp, problems)
        note = f"SIGKILL at {at:.2f} s; stale after it: {stale[:3]}" if stale else f"SIGKILL at {at:.2f} s"
        return Result(case, not problems, problems, r.seconds, r.err + r2.err, note=note)

    def race_case(self, case, box, tmp, logs, before, inputs_before):
        variants = case.params["variants"]
        procs = []
        for k, v in enumerate(variants):
            t = os.path.join(tmp, str(k))
            os.makedirs(t)
            procs.append(self.runner.start(case.tool, self.args(case, case.args + v), box, t,
                                           os.path.join(logs, f"run{k}")))
        runs = [self.runner.finish(p, self.timeout(case)) for p in procs]
        problems = []
        for r in runs:
            judge_run(case, r, problems, {0, 2})
        codes = sorted(r.rc for r in runs)
        if codes != [0, 2]:
            problems.append(f"exit codes {codes}: exactly one run must win (0) and the other be refused (2)")
        after = snapshot(box)
        winners = [k for k, r in enumerate(runs) if r.rc == 0]
        for k, r in enumerate(runs):
            if r.rc == 2:
                judge_message(case, r, problems)
        if len(winners) == 1:
            for o in case.outputs:
                if not os.path.exists(os.path.join(box, o)):
                    problems.append(f"output {o} missing after the race")
            problems += self.race_outputs_from(case, box, variants, winners[0])
        judge_files(case, before, after, case.outputs, problems, inputs_before, snapshot(self.inputs.dir))
        for k in range(len(variants)):
            self.check_tmp(os.path.join(tmp, str(k)), problems)
        return Result(case, not problems, problems, max(r.seconds for r in runs), "\n".join(r.err for r in runs))

    def race_outputs_from(self, case, box, variants, winner):
        """Every output of the race must come from the run that exited 0."""
        problems = []
        mark = " ".join(variants[winner])
        h5s = []
        for o in case.outputs:
            p = os.path.join(box, o)
            if os.path.isdir(p):
                h5s += [os.path.join(p, f) for f in sorted(os.listdir(p)) if f.endswith(".h5")]
            elif p.endswith(".h5"):
                h5s.append(p)
        for p in h5s:
            try:
                with h5py.File(p, "r") as f:
                    last = f["provenance/history"][-1]
                    last = last.decode() if isinstance(last, bytes) else str(last)
            except Exception as e:  # noqa: BLE001 - an unreadable output is the finding
                problems.append(f"output {os.path.relpath(p, box)} unreadable after the race: {e}")
                continue
            if mark not in last:
                problems.append(f"{os.path.relpath(p, box)} is not from the run that exited 0 ({mark})")
        html = os.path.join(box, "report.html")
        if case.tool == "report" and os.path.exists(html):
            import base64
            page = open(html, errors="replace").read()
            title = variants[winner][variants[winner].index("--title") + 1]
            if title not in page:
                problems.append("report.html is not from the run that exited 0")
            embedded = {hashlib.sha256(base64.b64decode(m)).hexdigest()
                        for m in re.findall(r"data:image/png;base64,([A-Za-z0-9+/=]+)", page)}
            img = os.path.join(box, "report_img")
            pngs = [f for f in os.listdir(img) if f.endswith(".png")] if os.path.isdir(img) else []
            foreign = [f for f in pngs if hashlib.sha256(open(os.path.join(img, f), "rb").read()).hexdigest()
                       not in embedded]
            if foreign:
                problems.append(f"report_img holds charts not on the page (another run's): {foreign[:3]}")
        return problems


# ------------------------------------------------------------------------------------------------ report

def tables(results, quick_or_subset):
    def row(rs):
        tried = [r for r in rs if r.handled is not None]
        return len(tried), sum(1 for r in tried if r.handled), sum(1 for r in rs if r.handled is None)
    lines = ["| kind | cases tried | handled | not handled | skipped |", "|---|---|---|---|---|"]
    for kind in KINDS:
        rs = [r for r in results if r.case.kind == kind]
        if rs:
            t, h, s = row(rs)
            lines.append(f"| {kind}: {KIND_TEXT[kind]} | {t} | {h} | {t - h} | {s} |")
    t, h, s = row(results)
    lines.append(f"| **all** | **{t}** | **{h}** | **{t - h}** | {s} |")
    by_tool = ["| tool | " + " | ".join(KINDS) + " | all |", "|---|" + "---|" * (len(KINDS) + 1)]
    for tool in TOOLS:
        rs = [r for r in results if r.case.tool == tool]
        if not rs:
            continue
        cells = []
        for kind in KINDS + [None]:
            t, h, _ = row([r for r in rs if kind is None or r.case.kind == kind])
            cells.append(f"{h}/{t}" if t else "-")
        by_tool.append(f"| {tool} | " + " | ".join(cells) + " |")
    return "\n".join(lines), "\n".join(by_tool)


def section_text(results, failing, by_kind, by_tool, elapsed, build, timeout, memory_gb):
    """The `reliability` section of docs/benchmarks.md: what ran, the rules, the tables, what failed."""
    text = (f"## Reliability: hostile inputs, options, outputs, signals and races\n\n"
            f"`bench/reliability.py` ran {len(results)} cases against the twelve tools ({build}; "
            f"{date.today().isoformat()}, {elapsed:.0f} s on {os.cpu_count()} cores). It makes its own small "
            f"inputs (a ctsynth series of two scans and the chain on it), runs each case in a folder of its own "
            f"and judges it by these rules:\n\n" + RULES.format(timeout=timeout, memory=memory_gb, wall=WALL_FACTOR) + "\n\n"
            f"### Cases tried and handled, by kind\n\n{by_kind}\n\n### By tool (handled / tried)\n\n{by_tool}\n\n")
    if failing:
        shown = failing[:MAX_LISTED]
        text += "### Not handled\n\n" + "\n".join(f"- `{r.case.id}`: {'; '.join(r.problems)}" for r in shown)
        if len(failing) > len(shown):
            text += f"\n- and {len(failing) - len(shown)} more (`bench/reliability.py --verbose` lists them)"
        text += "\n\n"
    return text


def version(bin_dir):
    try:
        return subprocess.run([os.path.join(bin_dir, "volinfo"), "--version"], capture_output=True, text=True,
                              timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(SOURCE, "build"))
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--tool", action="append", choices=TOOLS)
    ap.add_argument("--kind", action="append", choices=KINDS)
    ap.add_argument("--case", action="append")
    ap.add_argument("--list", action="store_true")
    ap.add_argument("--verbose", action="store_true")
    ap.add_argument("--work")
    ap.add_argument("--keep", action="store_true")
    ap.add_argument("--timeout", type=float, default=20.0)
    ap.add_argument("--memory-gb", type=float, default=4.0)
    ap.add_argument("--no-publish", action="store_true")
    a = ap.parse_args()
    bin_dir = os.path.join(os.path.abspath(a.build), "bin")
    missing = [t for t in TOOLS if not os.access(os.path.join(bin_dir, t), os.X_OK)]
    if missing:
        sys.exit(f"reliability.py: {bin_dir} lacks {', '.join(missing)}; build them first or pass --build DIR")
    tools = a.tool or TOOLS
    kinds = a.kind or KINDS
    # the signal cases time themselves against the valid run: keep it when signals are asked for
    if "signal" in kinds and "valid" not in kinds:
        kinds = ["valid"] + kinds
    cases = all_cases(bin_dir, tools, kinds)
    if a.quick:
        cases = [c for c in cases if c.quick]
    if a.case:
        cases = [c for c in cases if c.kind == "valid" or any(t in c.id for t in a.case)]
    if a.list:
        for c in cases:
            print(f"{c.id:70s} {c.kind:12s} {c.tool}")
        print(f"{len(cases)} cases")
        return 0
    work = os.path.abspath(a.work) if a.work else tempfile.mkdtemp(prefix="graintwin-reliability-")
    os.makedirs(work, exist_ok=True)
    runner = Runner(bin_dir, work, a.timeout, a.memory_gb)
    inputs = Inputs(work, runner)
    if not inputs.make():
        print(f"work folder kept for a look: {work}")
        return 3
    shutil.rmtree(os.path.join(work, "cases"), ignore_errors=True)
    harness = Harness(runner, inputs, work, a.keep)
    results = []
    t0 = time.monotonic()
    for c in cases:
        res = harness.run_case(c)
        results.append(res)
        mark = "skip" if res.handled is None else "ok  " if res.handled else "FAIL"
        detail = res.note if res.handled is None else "; ".join(res.problems)
        print(f"{mark} {res.seconds:6.2f}s {c.id}" + (f"  -- {detail}" if detail else ""), flush=True)
        if a.verbose and res.handled is False and res.err.strip():
            print("      " + "\n      ".join(res.err.strip().splitlines()[-12:]))
    elapsed = time.monotonic() - t0
    by_kind, by_tool = tables(results, a.quick)
    failing = [r for r in results if r.handled is False]
    print(f"\n{by_kind}\n\n{by_tool}\n")
    print(f"{len(results)} cases in {elapsed:.0f} s; {len(failing)} not handled")
    subset = a.quick or a.tool or a.kind or a.case
    if subset or a.no_publish:
        print("not published (" + ("a subset" if subset else "--no-publish") + ")")
    else:
        text = section_text(results, failing, by_kind, by_tool, elapsed, version(bin_dir), a.timeout, a.memory_gb)
        publish("reliability", text)
    if not a.work and not a.keep:
        shutil.rmtree(work, ignore_errors=True)
    elif a.keep:
        print(f"work folder kept: {work}")
    return 1 if failing else 0


if __name__ == "__main__":
    sys.exit(main())
