#!/usr/bin/python3
"""Server benchmark plots: frames delivered per subscriber count, and memory with a stalled
subscriber over time.

Reads bench/results/server_fanout.csv and server_stalled_memory.csv (written by server_bench)
and writes server.png beside them.
"""
import csv
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

results = Path(sys.argv[1] if len(sys.argv) > 1 else "bench/results")
fanout = list(csv.DictReader(open(results / "server_fanout.csv")))
memory = list(csv.DictReader(open(results / "server_stalled_memory.csv")))

fig, (left, middle, right) = plt.subplots(1, 3, figsize=(15, 4.2))

live = [r for r in fanout if r["part"] == "live"]
idle = max(float(r["simulated_or_encoded_fps"]) for r in live if r["subscribers"] == "0")
counts = [r["subscribers"] for r in live if r["subscribers"] != "0"]
slowdown = [100 * (1 - float(r["simulated_or_encoded_fps"]) / idle)
            for r in live if r["subscribers"] != "0"]
left.bar(counts, slowdown, color="tab:orange")
left.axhline(5, color="grey", linestyle="--", label="target (4 subscribers)")
left.set_xlabel("subscribers")
left.set_ylabel("simulation slowdown (%)")
left.set_title(f"Thesis scene, live (idle: {idle:.1f} frames/s)")
left.legend()

pipeline = [r for r in fanout if r["part"].startswith("pipeline")]
labels = [f"{r['scene']}\n{r['subscribers']} sub."
          + ("\nreceive only" if r["part"].endswith("receive_only") else "") for r in pipeline]
middle.bar(range(len(pipeline)), [float(r["delivered_fps_min"]) for r in pipeline])
middle.axhline(60, color="grey", linestyle="--", label="60 frames/s")
middle.set_xticks(range(len(pipeline)))
middle.set_xticklabels(labels, fontsize=7)
middle.set_ylabel("frames/s delivered (slowest subscriber)")
middle.set_title("Pipeline capacity (encode, gRPC, decode)")
middle.legend()

t = [float(r["seconds"]) for r in memory]
rss = [float(r["rss_mib"]) for r in memory]
history = [float(r["history_mib"]) for r in memory]
right.plot(t, rss, label="process RSS")
right.plot(t, history, label="step-back history (budget 256 MiB)")
right.plot(t, [a - b for a, b in zip(rss, history)], label="RSS less history")
right.set_xlabel("wall time (s)")
right.set_ylabel("MiB")
right.set_title("Stalled subscriber, thesis scene")
right.legend(fontsize=8)

fig.tight_layout()
fig.savefig(results / "server.png", dpi=110)
print(f"wrote {results / 'server.png'}")
