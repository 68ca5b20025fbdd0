#!/usr/bin/python3
"""Accuracy-against-cost chart for a fidelity knob: reads a CSV with columns
series,label,x,y and draws one line per series with each point labelled, log-log axes.
usage: plot_xy.py data.csv out.png "title" "x label" "y label" """
import csv
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

data, out, title, xlabel, ylabel = sys.argv[1:6]
series = defaultdict(list)
with open(data) as f:
    for row in csv.DictReader(f):
        series[row["series"]].append((float(row["x"]), float(row["y"]), row["label"]))
fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=110)
for name, pts in series.items():
    ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", label=name)
    for x, y, lab in pts:
        ax.annotate(lab, (x, y), textcoords="offset points", xytext=(4, 4), fontsize=8)
ax.set_xscale("log")
ax.set_yscale("log")
ax.set_xlabel(xlabel)
ax.set_ylabel(ylabel)
ax.set_title(title)
ax.grid(True, which="both", alpha=0.3)
if len(series) > 1:
    ax.legend()
fig.tight_layout()
fig.savefig(out)
