#!/usr/bin/python3
"""Stacked bars of milliseconds per step by pass, one bar per thread count.

Reads bench/results/seed_step.csv (written by seed_step_bench) and writes seed_step.png beside it.
"""
import csv
import sys
from collections import defaultdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

results = Path(sys.argv[1] if len(sys.argv) > 1 else "bench/results")
rows = list(csv.DictReader(open(results / "seed_step.csv")))
by_threads = defaultdict(dict)
passes = []
for r in rows:
    by_threads[int(r["threads"])][r["pass"]] = float(r["ms_per_step"])
    if r["pass"] not in passes:
        passes.append(r["pass"])
threads = sorted(by_threads)
fig, ax = plt.subplots(figsize=(6, 4))
bottom = [0.0] * len(threads)
for name in passes:
    values = [by_threads[t].get(name, 0.0) for t in threads]
    ax.bar([str(t) for t in threads], values, bottom=bottom, label=name)
    bottom = [b + v for b, v in zip(bottom, values)]
for x, total in enumerate(bottom):
    ax.text(x, total, f"{total:.1f} ms", ha="center", va="bottom")
ax.set_xlabel("threads")
ax.set_ylabel("ms per step")
ax.set_title(f"{rows[0]['scene']}: time per step by pass")
ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig(results / "seed_step.png", dpi=120)
print(f"wrote {results / 'seed_step.png'}")
