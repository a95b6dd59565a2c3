#!/usr/bin/env python3
"""Strong and weak scaling of `mpirun -np N dysa run` (docs/distributed.md).

Strong: the same scene on each rank count. Weak: particle_spacing scaled by N^(-1/3), so that the
particle count grows with N (each rank keeps about as many particles as one rank at N = 1). For
each run it records the throughput, the slowest rank's exchange time and its share of the step
(the exchange includes waiting for the slowest rank; also without that wait), the bytes sent and the ghosts received per
step, and the state hash (strong: the same at every N). Writes bench/results/scaling.csv and
scaling.png.

    /usr/bin/python3 bench/scaling_bench.py                       # 1, 2 ranks, 1 thread each
    /usr/bin/python3 bench/scaling_bench.py --ranks 1 2 4 8 --threads 2 --steps 200 \\
        --scene spheric_test2 --set particle_spacing=0.02          # on a bigger host
"""
import argparse
import csv
import pathlib
import re
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent


def run(args, ranks, spacing):
    command = ["mpirun", "--oversubscribe", "--allow-run-as-root", "-np", str(ranks),
               str(args.dysa), "run", args.scene, "--steps", str(args.steps), "--threads",
               str(args.threads), "--hash", "--out", f"/tmp/dysa_scaling_{ranks}"]
    for assignment in args.set:
        command += ["--set", assignment]
    if spacing is not None:
        command += ["--set", f"particle_spacing={spacing:.6g}"]
    env = {"OMP_WAIT_POLICY": "PASSIVE", "PATH": "/usr/bin:/bin"}
    out = subprocess.run(command, capture_output=True, text=True, env=env)
    if out.returncode != 0:
        sys.exit(f"{' '.join(command)} failed:\n{out.stdout}{out.stderr}")
    text = out.stdout
    passes = dict(re.findall(r"^([a-z_]+) +([0-9.]+) +[0-9.]+%$", text, re.M))
    run_line = re.search(r"^(\d+) steps of (\d+) particles in ([0-9.e+]+) s", text, re.M)
    moved = re.search(r"ghosts per step: ([0-9.e+]+); bytes sent per step: ([0-9.e+]+)", text)
    own = re.search(r"exchange without waiting: ([0-9.e+]+) ms per step .*waiting for the slowest "
                    r"rank first: ([0-9.e+]+) ms per step", text)
    step_ms = sum(float(v) for v in passes.values())
    return {
        "ranks": ranks,
        "threads": args.threads,
        "particles": int(run_line.group(2)),
        "steps": int(run_line.group(1)),
        "wall_s": float(run_line.group(3)),
        "million_particle_steps_per_s":
            int(run_line.group(2)) * int(run_line.group(1)) / float(run_line.group(3)) / 1e6,
        "step_ms": step_ms,
        "exchange_ms": float(passes["exchange"]),
        "exchange_share": float(passes["exchange"]) / step_ms if step_ms > 0 else 0.0,
        # The decomposition's whole cost: the exchange and, after the step, dropping the ghosts
        # and taking the next exchange's keys (one process without ranks does neither).
        "drop_ghosts_ms": float(passes.get("drop_ghosts", 0)),
        "halo_share": (float(passes["exchange"]) + float(passes.get("drop_ghosts", 0))) / step_ms
        if step_ms > 0 else 0.0,
        # The same without the wait for the slowest rank at the exchange's start (the ranks'
        # imbalance, which the balance target covers): the exchange's own packing, transfer and
        # sort (each the longest over the ranks).
        "exchange_own_ms": float(own.group(1)),
        "wait_ms": float(own.group(2)),
        "halo_share_own": (float(own.group(1)) + float(passes.get("drop_ghosts", 0))) / step_ms
        if step_ms > 0 else 0.0,
        "ghosts_per_step": float(moved.group(1)),
        "bytes_per_step": float(moved.group(2)),
        "hash": re.search(r"^state hash: (0x[0-9a-f]+)", text, re.M).group(1),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--dysa", default=ROOT / "build/release/clients/cli/dysa")
    parser.add_argument("--scene", default="dam_break_martin_moyce")
    parser.add_argument("--set", action="append", default=[], help="NAME=VALUE for every run")
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--threads", type=int, default=1, help="OpenMP threads per rank")
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--spacing", type=float, default=0.001905,
                        help="particle_spacing of the weak runs at 1 rank (m)")
    parser.add_argument("--out", default=ROOT / "bench/results")
    args = parser.parse_args()

    rows = []
    for mode in ("strong", "weak"):
        for ranks in args.ranks:
            spacing = args.spacing * ranks ** (-1 / 3) if mode == "weak" else None
            row = {"mode": mode, **run(args, ranks, spacing)}
            rows.append(row)
            print(f"{mode:6} {ranks:2} ranks x {row['threads']} threads: {row['particles']:8} "
                  f"particles, {row['million_particle_steps_per_s']:.3f} M particle-steps/s, "
                  f"step {row['step_ms']:.2f} ms, exchange {row['exchange_ms']:.2f} ms "
                  f"({100 * row['exchange_share']:.0f}%), drop_ghosts {row['drop_ghosts_ms']:.2f} ms "
                  f"(both {100 * row['halo_share']:.0f}%; without the wait "
                  f"{row['exchange_own_ms']:.2f} ms, both {100 * row['halo_share_own']:.0f}%), "
                  f"{row['bytes_per_step']:.3g} B/step, "
                  f"hash {row['hash']}", flush=True)
    strong_hashes = {r["hash"] for r in rows if r["mode"] == "strong"}
    if len(strong_hashes) != 1:
        sys.exit(f"strong scaling runs differ in their state hash: {sorted(strong_hashes)}")

    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "scaling.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
    for mode, marker in (("strong", "o"), ("weak", "s")):
        sel = [r for r in rows if r["mode"] == mode]
        left.plot([r["ranks"] for r in sel], [r["million_particle_steps_per_s"] for r in sel],
                  marker=marker, label=mode)
        right.plot([r["ranks"] for r in sel], [100 * r["exchange_share"] for r in sel],
                   marker=marker, label=mode)
    left.set(xlabel="ranks", ylabel="million particle-steps/s", title="throughput")
    right.set(xlabel="ranks", ylabel="% of the step", title="exchange (with waiting)")
    for ax in (left, right):
        ax.legend()
        ax.grid(alpha=0.3)
    fig.suptitle(f"{args.scene}, {args.threads} thread(s) per rank, {args.steps} steps")
    fig.tight_layout()
    fig.savefig(out / "scaling.png", dpi=100)
    print(f"wrote {out / 'scaling.csv'} and {out / 'scaling.png'}")


if __name__ == "__main__":
    main()
