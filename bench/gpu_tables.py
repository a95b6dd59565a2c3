#!/usr/bin/env python3
"""Markdown tables of gpu_bench's and server_bench --part gpu's CSV files, for bench/README.md.

    /usr/bin/python3 bench/gpu_tables.py [RESULTS_DIR] [GPU_TAG]     (default: bench/results NVIDIA_H200)
"""
import csv
import os
import sys


def read(path):
    with open(path, encoding="utf-8") as f:
        return list(csv.DictReader(f))


def summary(results, solver, tag):
    path = os.path.join(results, f"gpu_{solver}_{tag}.csv")
    if not os.path.exists(path):
        return
    rows = read(path)
    print(f"\n`{solver}` ({os.path.basename(path)}):\n")
    print("| device | particles | ms/step | particle-steps/s | neighbours | pairs/s | "
          "simulated s per wall s | GPU bytes/particle | speed-up |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for r in rows:
        gpu = r["device"] != "cpu"
        speedup = float(r["speedup_over_cpu"])
        print(f"| {'GPU' if gpu else 'CPU, all cores'} | {int(r['particles']):,} | "
              f"{float(r['ms_per_step']):.3g} | {float(r['particle_steps_per_s']):.3g} | "
              f"{float(r['neighbours']):.1f} | {float(r['pairs_per_s']):.3g} | "
              f"{float(r['simulated_s_per_wall_s']):.3g} | "
              f"{float(r['device_bytes_per_particle']):.0f} | "
              f"{f'{speedup:.1f}x' if gpu and speedup > 0 else ''} |")


def passes(results, solver, tag):
    path = os.path.join(results, f"gpu_{solver}_passes_{tag}.csv")
    if not os.path.exists(path):
        return
    rows = [r for r in read(path) if r["device"] != "cpu"]
    sizes = sorted({int(r["particles"]) for r in rows})
    names = list(dict.fromkeys(r["pass"] for r in rows))
    ms = {(int(r["particles"]), r["pass"]): float(r["ms"]) for r in rows}
    print(f"\n`{solver}` on the GPU, ms per pass:\n")
    print("| pass | " + " | ".join(f"{n:,}" for n in sizes) + " |")
    print("| --- |" + " ---: |" * len(sizes))
    for name in names:
        cells = [f"{ms[(n, name)]:.3f}" if (n, name) in ms else "" for n in sizes]
        print(f"| {name} | " + " | ".join(cells) + " |")


def server(results):
    path = os.path.join(results, "server_gpu.csv")
    if not os.path.exists(path):
        return
    print("\nThe server (server_gpu.csv):\n")
    print("| particles | subscribers | simulated frames/s | delivered frames/s | bytes/frame | "
          "step ms | gather ms | publish ms | target | met |")
    print("| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |")
    for r in read(path):
        print(f"| {int(r['particles']):,} | {r['subscribers']} | {float(r['simulated_fps']):.1f} | "
              f"{float(r['delivered_fps']):.1f} | {float(r['bytes_per_frame']):.3g} | "
              f"{float(r['step_ms']):.2f} | {float(r['gather_ms']):.2f} | "
              f"{float(r['publish_ms']):.2f} | {r['target_fps']} | {r['target_met']} |")


def main():
    results = sys.argv[1] if len(sys.argv) > 1 else "bench/results"
    tag = sys.argv[2] if len(sys.argv) > 2 else "NVIDIA_H200"
    for solver in ("seed", "wcsph", "dfsph"):
        summary(results, solver, tag)
        passes(results, solver, tag)
    server(results)


if __name__ == "__main__":
    main()
