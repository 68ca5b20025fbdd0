#!/usr/bin/python3
"""The library's module graph (libcommon/src/<module>, libcommon/include/graintwin/<module>) against
its declared layering: every `#include "graintwin/<other>/..."` of a module must be a dependency
DEPENDS below allows, so a new upward include or cycle fails (ctest label `architecture`).
Known debt is listed with the file that causes it; it fails too once it is gone, so the list stays true.

usage: module_graph.py [SOURCE_DIR]            check (exit 1 on a violation)
       module_graph.py [SOURCE_DIR] --markdown print the graph as the table in docs/where-things-live.md
SOURCE_DIR is the repository's root, by default the one holding this script.
"""
import glob
import os
import re
import sys

# What each module may include, bottom layer first. A module may always include itself.
DEPENDS = {
    "core": set(),
    "io": {"core"},
    "cli": {"core", "io"},
    "shape": {"core", "io"},
    "segment": {"core", "io"},
    "synth": {"core", "io", "shape", "segment"},
    "contacts": {"core", "io", "segment"},
    "track": {"core", "io", "shape"},
    "fdem": {"core", "io"},
    "mpi": {"core", "fdem"},
    "mesh": {"core", "io", "fdem", "shape", "synth"},
    "experiment": {"core", "io", "fdem", "mesh", "shape", "synth"},
    "micro": {"core", "io", "contacts", "fdem", "shape"},
    "validate": {"core", "io", "contacts", "fdem", "micro", "segment", "shape", "synth", "track"},
    "report": {"core", "io", "contacts", "fdem", "micro", "segment", "shape", "track", "validate"},
}
# Edges that break the layering today, with the file that makes them: to be removed, not added to.
KNOWN_DEBT = {}
INCLUDE = re.compile(r'^\s*#\s*include\s+"graintwin/([a-z_0-9]+)/', re.M)


def module_edges(source):
    """{(module, dependency): [files]} over the library's sources and headers."""
    edges = {}
    for root in ("libcommon/src", "libcommon/include/graintwin"):
        base = os.path.join(source, root)
        for path in sorted(glob.glob(os.path.join(base, "**", "*.[ch]pp"), recursive=True)):
            parts = os.path.relpath(path, base).split(os.sep)
            if len(parts) < 2:
                continue  # files beside the modules (version.hpp) belong to none
            module = parts[0]
            with open(path, encoding="utf-8") as f:
                for dep in INCLUDE.findall(f.read()):
                    if dep != module:
                        edges.setdefault((module, dep), []).append(os.path.relpath(path, source))
    return edges


def find_cycle(edges):
    graph = {}
    for a, b in edges:
        graph.setdefault(a, set()).add(b)
    state, stack = {}, []

    def visit(n):
        state[n] = 1
        stack.append(n)
        for m in sorted(graph.get(n, ())):
            if state.get(m) == 1:
                return stack[stack.index(m):] + [m]
            if state.get(m) is None:
                found = visit(m)
                if found:
                    return found
        stack.pop()
        state[n] = 2
        return None

    for n in sorted(graph):
        if state.get(n) is None:
            found = visit(n)
            if found:
                return found
    return None


def main():
    given = [a for a in sys.argv[1:] if not a.startswith("--")]
    source = given[0] if given else os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
    if not os.path.isdir(os.path.join(source, "libcommon")):
        print(f"{source} holds no libcommon/; pass the repository's root\n{__doc__[__doc__.index('usage:'):].rstrip()}", file=sys.stderr)
        return 2
    edges = module_edges(source)
    if "--markdown" in sys.argv:
        print("| module | includes |\n|---|---|")
        for m in DEPENDS:
            deps = sorted(b for (a, b) in edges if a == m)
            print(f"| `{m}` | {', '.join(f'`{d}`' + (' (debt)' if (m, d) in KNOWN_DEBT else '') for d in deps) or '-'} |")
        return 0
    problems = []
    for (a, b), files in sorted(edges.items()):
        if a not in DEPENDS:
            problems.append(f"module {a} is not in the layering ({files[0]}); add it to DEPENDS in {__file__}")
        elif b not in DEPENDS[a] and (a, b) not in KNOWN_DEBT:
            problems.append(f"{a} must not include {b}: {', '.join(files)} (a module includes only those below it; "
                            f"move the shared code down, or change the layering in {os.path.basename(__file__)} and "
                            "docs/where-things-live.md together)")
    for (a, b), why in KNOWN_DEBT.items():
        if (a, b) not in edges:
            problems.append(f"the known debt {a} -> {b} ({why}) is gone: remove it from KNOWN_DEBT")
    allowed = {e for e in edges if e not in KNOWN_DEBT}
    cycle = find_cycle(allowed)
    if cycle:
        problems.append("the allowed includes form a cycle: " + " -> ".join(cycle))
    for p in problems:
        print(p, file=sys.stderr)
    if not problems:
        print(f"module graph: {len(edges)} module dependencies, {len(KNOWN_DEBT)} known debt, no cycle")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
