"""Shared by the Python benchmarks: rewrites one section of docs/benchmarks.md, the part between
<!-- bench:NAME --> and <!-- /bench:NAME --> (appended when it is not there yet)."""
import json
import os
import platform
import sys

SOURCE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def publish(name, text):
    path = os.path.join(SOURCE, "docs", "benchmarks.md")
    begin, end = f"<!-- bench:{name} -->", f"<!-- /bench:{name} -->"
    doc = open(path).read() if os.path.exists(path) else "# Benchmarks\n"
    section = begin + "\n" + text + end
    b, e = doc.find(begin), doc.find(end)
    doc = doc[:b] + section + doc[e + len(end):] if b >= 0 and e > b else doc + "\n" + section + "\n"
    with open(path, "w") as f:
        f.write(doc)
    print("updated", path, f"(section {name})")


def finish(name, text, run_dir, results, publish_it=True):
    """A bench's end: prints its text, keeps its raw results as run_dir/NAME.json and, unless told
    not to, publishes the text as section NAME."""
    print(text)
    with open(os.path.join(run_dir, name + ".json"), "w") as f:
        json.dump(results, f, indent=1)
    if publish_it:
        publish(name, text)


def cpu_model():
    """The machine's CPU model (/proc/cpuinfo), for a section's header."""
    try:
        return next(l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name"))
    except (OSError, StopIteration):
        return platform.machine()


def publish_runs(name, text, failed):
    """A bench of several runs ends: prints and publishes its text, then exits non-zero naming the
    runs that did not finish, if any."""
    print(text)
    publish(name, text)
    if failed:
        sys.exit(f"{name}: {', '.join(failed)} did not finish; the others were published")
