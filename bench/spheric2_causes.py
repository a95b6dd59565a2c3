#!/usr/bin/env python3
"""The measures of bench/spheric2_causes.sh's variants, one CSV row each.

For each --run NAME WALL_MS STEPS_CSV (accuracy_bench --step-series output): P1 and P2 arrival
(the 1 ms average's first crossing of 500 Pa) and error against MARIN, the 1 ms and 5 ms peaks
in 0.40-0.46 s, and the H1-H4 RMS errors to 0.75 s, with peer_compare.py's definitions.
"""
import argparse
import csv
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import peer_compare  # noqa: E402


def main(argv=None):
    here = os.path.dirname(os.path.abspath(__file__))
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--run", nargs=3, action="append", required=True,
                   metavar=("NAME", "WALL_MS", "STEPS_CSV"))
    p.add_argument("--dp", required=True, help="the spacing (m), for the rows")
    p.add_argument("--out", required=True, help="the CSV to write")
    p.add_argument("--repo", default=os.path.dirname(here))
    args = p.parse_args(argv)
    ref_t, ref_h = peer_compare.read_marin_heights(args.repo)
    marin = peer_compare.MARIN_PRESSURE
    keys = ["P1_arrival_s", "P1_peak_1ms_pa", "P1_peak_5ms_pa", "P1_peak_1ms_time_s",
            "P2_arrival_s", "P2_peak_1ms_pa", "P2_peak_5ms_pa"]
    keys += [f"H{g}_rms_to_0.75s" for g in range(1, 5)]
    rows = []
    for name, wall_ms, path in args.run:
        series = peer_compare.read_project_steps(path)
        r = peer_compare.spheric_measures(series, ref_t, ref_h, None)
        r["P1_arrival_error_ms"] = (1000 * (r["P1_arrival_s"] - marin["P1_arrival_s"])
                                    if r["P1_arrival_s"] is not None else None)
        r.update(variant=name, dp_m=args.dp, wall_s=float(wall_ms) / 1000,
                 steps=len(series["P1"][0]) - 1)
        rows.append(r)
        print(f"{name:11s} P1 arrival {peer_compare.fmt(r['P1_arrival_error_ms'])} ms, peak 1 ms "
              f"{peer_compare.fmt(r['P1_peak_1ms_pa'])} Pa, 5 ms "
              f"{peer_compare.fmt(r['P1_peak_5ms_pa'])} Pa; H4 {peer_compare.fmt(r['H4_rms_to_0.75s'])}"
              f"; {r['steps']} steps in {r['wall_s']:.1f} s")
    columns = ["variant", "dp_m", "steps", "wall_s", "P1_arrival_error_ms"] + keys
    with open(args.out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(columns)
        for r in rows:
            w.writerow([peer_compare.fmt(r.get(k)) if isinstance(r.get(k), float) else r.get(k)
                        for k in columns])
    print(f"wrote {args.out}")


if __name__ == "__main__":
    try:
        main()
    except peer_compare.InputError as e:
        sys.exit(f"spheric2_causes.py: {e}")
