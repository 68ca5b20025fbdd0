#!/usr/bin/python3
"""Draws the report's charts (tools/report.cpp writes their specification; docs/report.md).

usage: report_charts.py CHARTS.json OUT_DIR

CHARTS.json holds {"charts": [chart, ...]}; each chart has file (PNG name in OUT_DIR), panel,
kind ("xy" or "rose"), title, x_label, y_label, x_log, y_log and series [{name, style, x, y,
group}]; series of one non-empty group share a colour (a fit and its data).
xy styles: line, dashed, points, linepoints, vline (a vertical line at each x). A rose series has
x = polar-angle bin edges in degrees from the loading axis z and y = one value per bin; it is
drawn as a closed outline in the x-z plane, mirrored about both axes. Charts of one panel share
their axis limits so experiment and simulation compare at a glance. Kind "section" (pictures of the
sample: label slices and the twin's outlines) is drawn by report_sections.py, kinds "network" (the
3D force-chain network), "grains" (D2min clusters, eps_q in 3D) and "surfaces" (the grains' own
shapes in 3D) by report_3d.py with VTK. The script computes
nothing but limits: every number comes from the JSON. The charts are drawn by one process per core
(each 3D one with its own Xvfb); the first error stops the script with its message.
"""
import ctypes
import json
import math
import multiprocessing
import os
import signal
import sys
import traceback

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import report_sections  # noqa: E402  (beside this script)

STYLES = {
    "line": dict(linestyle="-", marker=None),
    "dashed": dict(linestyle="--", marker=None),
    "points": dict(linestyle="none", marker="o", markersize=4),
    "linepoints": dict(linestyle="-", marker="o", markersize=3),
}


def finite(values, log):
    return [v for v in values if v is not None and math.isfinite(v) and (not log or v > 0)]


def xy_limits(charts):
    """Shared (x, y) limits of the xy charts of one panel: the union of their data ranges."""
    xs, ys = [], []
    for c in charts:
        for s in c["series"]:
            xs += finite(s["x"], c["x_log"])
            if s["style"] != "vline":
                ys += finite(s["y"], c["y_log"])
    def pad(values, log):
        if not values:
            return None
        lo, hi = min(values), max(values)
        if log:
            return (lo / 1.3, hi * 1.3)
        span = (hi - lo) or abs(hi) or 1.0
        return (lo - 0.05 * span, hi + 0.05 * span)
    return pad(xs, charts[0]["x_log"]), pad(ys, charts[0]["y_log"])


def draw_xy(ax, chart, limits):
    colours = {}  # group -> colour: a fit is drawn in its data's colour
    for s in chart["series"]:
        if s["style"] == "vline":
            for k, x in enumerate(s["x"]):
                ax.axvline(x, color="grey", linestyle=":", label=s["name"] if k == 0 else None)
            continue
        extra = {"color": colours[s["group"]]} if s["group"] in colours else {}
        (line,) = ax.plot(s["x"], s["y"], label=s["name"], **STYLES.get(s["style"], STYLES["line"]), **extra)
        if s["group"]:
            colours.setdefault(s["group"], line.get_color())
    if chart["x_log"]:
        ax.set_xscale("log")
    if chart["y_log"]:
        ax.set_yscale("log")
    xlim, ylim = limits
    if xlim:
        ax.set_xlim(*xlim)
    if ylim:
        ax.set_ylim(*ylim)
    ax.set_xlabel(chart["x_label"])
    ax.set_ylabel(chart["y_label"])
    ax.grid(True, which="both", alpha=0.3)


def draw_rose(ax, chart, radius):
    for s in chart["series"]:
        edges = [math.radians(e) for e in s["x"]]
        # One quadrant as steps over the polar-angle bands (angle from +z), then mirrored.
        theta, r = [], []
        for k, v in enumerate(s["y"]):
            theta += [edges[k], edges[k + 1]]
            r += [v, v]
        quadrants = [theta, [math.pi - t for t in reversed(theta)],
                     [math.pi + t for t in theta], [2 * math.pi - t for t in reversed(theta)]]
        radii = [r, list(reversed(r)), r, list(reversed(r))]
        all_t = [t for q in quadrants for t in q]
        all_r = [v for q in radii for v in q]
        ax.plot(all_t + all_t[:1], all_r + all_r[:1], label=s["name"])
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    if radius:
        ax.set_ylim(0, radius)
    ax.set_xlabel(chart["y_label"])


def draw_chart(chart, group, out_dir):
    """One chart's PNG; `group` holds the charts of its panel (shared limits)."""
    if chart["kind"] == "section":
        report_sections.draw(chart, os.path.join(out_dir, chart["file"]))
        return
    if chart["kind"] in ("network", "grains", "surfaces"):
        import report_3d  # VTK and its Xvfb only when a run has a 3D picture to draw

        draw_3d = {"network": report_3d.draw_network, "grains": report_3d.draw_grains,
                   "surfaces": report_3d.draw_surfaces}[chart["kind"]]
        draw_3d(chart, os.path.join(out_dir, chart["file"]))
        return
    if chart["kind"] == "rose":
        values = [v for c in group for s in c["series"] for v in finite(s["y"], False)]
        fig = plt.figure(figsize=(5.6, 5.0), dpi=100)
        ax = fig.add_subplot(projection="polar")
        draw_rose(ax, chart, 1.1 * max(values) if values and max(values) > 0 else None)
    else:
        fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=100)
        draw_xy(ax, chart, xy_limits(group))
    ax.set_title(chart["title"])
    if any(s["name"] for s in chart["series"]):
        ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, chart["file"]))
    plt.close(fig)


_work = None  # (charts, panels, out_dir), set before the workers fork


def die_with_parent():
    """A worker ends when the script does (PR_SET_PDEATHSIG), as the script ends with the report."""
    ctypes.CDLL("libc.so.6").prctl(1, signal.SIGKILL)


def draw_in_worker(index):
    """Draws chart `index`; returns None, or the error that stopped it (a worker must not exit)."""
    charts, panels, out_dir = _work
    try:
        draw_chart(charts[index], panels[charts[index]["panel"]], out_dir)
    except SystemExit as e:
        return str(e.code)
    except Exception:  # noqa: BLE001  (reported by the parent with its traceback)
        return traceback.format_exc()
    return None


# Slowest first, so the workers finish together: 3D pictures, then sections, then charts.
COST = {"surfaces": 0, "grains": 1, "network": 2, "section": 3}


def main():
    global _work
    spec_path, out_dir = sys.argv[1:3]
    with open(spec_path) as f:
        charts = json.load(f)["charts"]
    panels = {}
    for c in charts:
        panels.setdefault(c["panel"], []).append(c)
    _work = (charts, panels, out_dir)
    order = sorted(range(len(charts)), key=lambda i: COST.get(charts[i]["kind"], 4))
    # One process per core: the pictures are independent, and a 15 000-grain run has about 80.
    workers = min(len(os.sched_getaffinity(0)), max(len(charts), 1))
    if workers == 1:
        errors = [draw_in_worker(i) for i in order]
    else:
        with multiprocessing.get_context("fork").Pool(workers, initializer=die_with_parent) as pool:
            errors = list(pool.imap_unordered(draw_in_worker, order))
    errors = [e for e in errors if e]
    if errors:
        sys.exit(errors[0])


if __name__ == "__main__":
    main()
