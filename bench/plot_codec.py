#!/usr/bin/python3
"""Bytes per particle of keyframes and delta frames, per field combination and frame sequence.

Reads bench/results/codec.csv (written by codec_bench) and writes codec.png beside it.
"""
import csv
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

results = Path(sys.argv[1] if len(sys.argv) > 1 else "bench/results")
rows = list(csv.DictReader(open(results / "codec.csv")))
sequences = list(dict.fromkeys(r["sequence"] for r in rows))
combos = list(dict.fromkeys(r["fields"] for r in rows))
fig, axes = plt.subplots(1, len(sequences), figsize=(4.2 * len(sequences), 4), sharey=True)
for ax, seq in zip(axes, sequences):
    for offset, kind in ((-0.2, "keyframe"), (0.2, "delta")):
        values = [
            next(float(r["bytes_per_particle"]) for r in rows
                 if r["sequence"] == seq and r["fields"] == c and r["kind"] == kind)
            for c in combos
        ]
        ax.bar([i + offset for i in range(len(combos))], values, width=0.4, label=kind)
    ax.set_xticks(range(len(combos)))
    ax.set_xticklabels(combos, rotation=35, ha="right", fontsize=8)
    particles = next(r["particles"] for r in rows if r["sequence"] == seq)
    ax.set_title(f"{seq} ({int(particles):,} particles)", fontsize=9)
    ax.axhline(2.5, color="grey", lw=0.8, ls="--")
    ax.axhline(4.5, color="grey", lw=0.8, ls=":")
axes[0].set_ylabel("bytes per particle (16-bit positions, 8-bit speed)")
axes[0].legend(fontsize=8)
fig.suptitle("Frame codec: dashed 2.5 B (delta target), dotted 4.5 B (keyframe target)", fontsize=9)
fig.tight_layout()
fig.savefig(results / "codec.png", dpi=110)
print(f"wrote {results / 'codec.png'}")
