#!/usr/bin/python3
"""Error against wall time of the validation cases, log-log, one panel per case, the Pareto
front (the settings no other setting beats in both time and error) drawn as a line.

Reads bench/results/accuracy.csv (written by accuracy_bench) and writes accuracy.png beside it.
"""
import csv
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

results = Path(sys.argv[1] if len(sys.argv) > 1 else "bench/results")
rows = list(csv.DictReader(open(results / "accuracy.csv")))
cases = list(dict.fromkeys(r["case"] for r in rows))
titles = {"hydrostatic": "Hydrostatic tank: mean pressure error",
          "dam_break": "Dam break (Martin & Moyce 1952): RMS front error",
          "poiseuille": "Poiseuille flow (Morris 1997): max velocity error / u_max"}
markers = {"wcsph": "o", "dfsph": "s"}


def pareto(points):
    """The points no other point beats in both wall time and error, by increasing time."""
    front = []
    for p in sorted(points, key=lambda p: (p[0], p[1])):
        if not front or p[1] < front[-1][1]:
            front.append(p)
    return front


fig, axes = plt.subplots(1, len(cases), figsize=(6.2 * len(cases), 4.6), squeeze=False)
for ax, case in zip(axes[0], cases):
    case_rows = [r for r in rows if r["case"] == case]
    settings = list(dict.fromkeys((r["solver"], r["setting"]) for r in case_rows))
    for solver, setting in settings:
        sel = [r for r in case_rows if r["solver"] == solver and r["setting"] == setting]
        xs = [float(r["wall_s"]) for r in sel]
        ys = [max(float(r["error"]), 1e-6) for r in sel]
        ax.plot(xs, ys, marker=markers.get(solver, "^"), linestyle=":",
                label="%s %s" % (solver, setting))
        for r, x, y in zip(sel, xs, ys):
            ax.annotate("%.4g" % float(r["spacing_m"]), (x, y), fontsize=6,
                        textcoords="offset points", xytext=(3, 3))
    front = pareto([(float(r["wall_s"]), max(float(r["error"]), 1e-6)) for r in case_rows])
    ax.step([p[0] for p in front], [p[1] for p in front], where="post", color="black",
            linewidth=1.5, label="Pareto front")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time, s (2 threads)")
    ax.set_ylabel("relative error")
    ax.set_title(titles.get(case, case), fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
fig.tight_layout()
fig.savefig(results / "accuracy.png", dpi=110)
print("wrote", results / "accuracy.png")
