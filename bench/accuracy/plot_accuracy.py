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

# SPHERIC Test 2 (accuracy_bench --case spheric_test2), when it was run: its errors against wall
# time, and P1 and H4 over time beside the published arrival and peak and the MARIN heights.
spheric_csv = results / "accuracy_spheric_test2.csv"
if spheric_csv.exists():
    srows = list(csv.DictReader(open(spheric_csv)))
    fig, (ax_err, ax_p1, ax_h4) = plt.subplots(1, 3, figsize=(18, 4.6))
    walls = [float(r["wall_s"]) for r in srows]
    for key, label in (("h4_error_1s", "H4 RMS relative error, t <= 1 s"),
                       ("p1_peak_error", "|P1 filtered peak / 11 kPa - 1|"),
                       ("p1_arrival_error_s", "|P1 arrival - 0.393 s| / 0.1 s")):
        scale = 10.0 if key == "p1_arrival_error_s" else 1.0
        ys = [max(abs(float(r[key])) * scale, 1e-4) for r in srows]
        ax_err.plot(walls, ys, marker="o", linestyle=":", label=label)
        for r, x, y in zip(srows, walls, ys):
            ax_err.annotate("%.4g" % float(r["spacing_m"]), (x, y), fontsize=6,
                            textcoords="offset points", xytext=(3, 3))
    ax_err.set_xscale("log")
    ax_err.set_yscale("log")
    ax_err.set_xlabel("wall time, s (2 threads)")
    ax_err.set_ylabel("error")
    ax_err.set_title("SPHERIC Test 2 (wcsph, to 1 s)", fontsize=10)
    ax_err.grid(True, which="both", alpha=0.3)
    ax_err.legend(fontsize=7)
    marin = [line.strip().split(",") for line in
             open(Path(__file__).resolve().parents[2] /
                  "server/validation/data/spheric_test2_marin_heights.csv")
             if line[:1].isdigit()]
    ax_h4.plot([float(m[0]) for m in marin], [float(m[4]) for m in marin], "k--", linewidth=2,
               label="MARIN (Kleefsman et al. 2005)")
    for r in srows:
        series = list(csv.DictReader(open(results / ("spheric_test2_series_%.4f.csv"
                                                     % float(r["spacing_m"])))))
        t = [float(s["t_s"]) for s in series]
        label = "d = %.4g m" % float(r["spacing_m"])
        ax_p1.plot(t, [float(s["P1_pa"]) / 1000 for s in series], linewidth=0.8, label=label)
        ax_h4.plot(t, [float(s["H4_m"]) for s in series], linewidth=0.8, label=label)
    ax_p1.axvspan(0.39, 0.40, color="grey", alpha=0.3, label="published arrival 0.39-0.40 s")
    ax_p1.axhline(11, color="black", linestyle="--", linewidth=1, label="published peak 11 kPa")
    ax_p1.set_xlim(0.3, 1.0)
    ax_p1.set_xlabel("t, s")
    ax_p1.set_ylabel("P1, kPa (5 ms centred average)")
    ax_p1.legend(fontsize=7)
    ax_h4.set_xlim(0, 1.0)
    ax_h4.set_xlabel("t, s")
    ax_h4.set_ylabel("H4, m")
    ax_h4.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(results / "accuracy_spheric_test2.png", dpi=110)
    print("wrote", results / "accuracy_spheric_test2.png")
