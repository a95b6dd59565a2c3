#!/usr/bin/env python3
"""The water's tongue in front of a wall face, frame by frame: how thick, how fast and how blunt
the front is that strikes a pressure sensor (docs/validation.md, "What is wrong at impact").

  bench/impact_front.py OUT_DIR --dp DP [--face-x 0.8245] [--z 0.471] [--half-width 2dp]
                        [--reach 0.2] [--top 0.161] [--csv FILE]

Reads OUT_DIR/frames.pvd and its .vtp files (`dysa run --vtk-every N --vtk-from T0 --vtk-to T1
--out OUT_DIR`). The fluid comes from +x towards the face at x = face-x (SPHERIC Test 2's box).
In the slab |z - z_sensor| <= half-width and below the face's top (`top`: the water above it
flows over the box, it does not strike the face), the particles within `reach` of the face are binned by
their distance to it, one spacing per bin; per bin: the depth the particles' rest volume makes
(count dp^3 / (dp 2 half-width): spray counts for its water only), the top particle's height,
the mean velocity towards the face, the largest pressure, the mean density (a thin tongue
whose particles all lack neighbours carries less than rho0, and the Tait equation gives it no
pressure at all: docs/validation.md), and how many particles the wall contact holds (docs/solvers.md: none comes nearer than 0.2 dp to a surface, its velocity towards
it cut to 0: an inelastic stop). Per frame it prints the tip (the
particle nearest the face) and the depth at the tip and 2, 4 and 8 spacings behind it: a tongue
whose depth at its tip is already that of its body strikes with all of it at once. Last, the
first frame with water within one spacing of the face, and the first whose water there carries
pressure: the water's arrival and the pressure's. Plain Python
(no numpy), so that it runs on the GPU box next to the frames.
"""

import argparse
import csv
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vtp_leaders import read_vtp  # noqa: E402

_DATASET = re.compile(r'<DataSet timestep="([^"]+)"[^>]*file="([^"]+)"')


def frames_of(out_dir):
    """(time, path) of each frame named by OUT_DIR/frames.pvd, in time order."""
    pvd = os.path.join(out_dir, "frames.pvd")
    if not os.path.exists(pvd):
        sys.exit(f"{out_dir}: no frames.pvd (dysa run --vtk-every N --out DIR)")
    text = open(pvd).read()
    found = [(float(t), os.path.join(out_dir, f)) for t, f in _DATASET.findall(text)]
    if not found:
        sys.exit(f"{pvd}: no DataSet entries")
    return sorted(found)


def profile(frame, dp, face_x, z, half_width, reach, top=float("inf")):
    """Per bin of one spacing from the face: [count, top y, sum of vx towards the face, max p,
    count held by the wall contact (at 0.2 dp from the face, not moving towards it), sum of
    the density]."""
    bins = [[0, 0.0, 0.0, 0.0, 0, 0.0] for _ in range(int(round(reach / dp)))]
    x, v, p, rho = frame["position"], frame["velocity"], frame["pressure"], frame["density"]
    for k in range(len(frame["id"])):
        d = x[3 * k] - face_x
        if d < 0 or d >= reach or abs(x[3 * k + 2] - z) > half_width or x[3 * k + 1] > top:
            continue
        b = bins[min(int(d / dp), len(bins) - 1)]
        b[0] += 1
        b[1] = max(b[1], x[3 * k + 1])
        b[2] += -v[3 * k]
        b[3] = max(b[3], p[k])
        if abs(d - 0.2 * dp) < 1e-3 * dp and v[3 * k] == 0:
            b[4] += 1
        b[5] += rho[k]
    return bins


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out_dir")
    parser.add_argument("--dp", type=float, required=True, help="particle spacing, m")
    parser.add_argument("--face-x", type=float, default=0.8245, help="the face's x, m")
    parser.add_argument("--z", type=float, default=0.471, help="the sensor's z, m")
    parser.add_argument("--half-width", type=float,
                        help="slab half-width, m (default 2 dp: four spacings across)")
    parser.add_argument("--reach", type=float, default=0.2, help="distance from the face, m")
    parser.add_argument("--top", type=float, default=0.161, help="the face's top, m")
    parser.add_argument("--rho0", type=float, default=1000.0, help="rest density, kg/m^3")
    parser.add_argument("--csv", help="write every bin of every frame here")
    args = parser.parse_args(argv)
    if args.half_width is None:
        args.half_width = 2 * args.dp
    if args.dp <= 0 or args.half_width <= 0 or args.reach < args.dp:
        sys.exit("--dp and --half-width must be > 0 and --reach at least --dp")
    area = args.dp * 2 * args.half_width  # a bin's footprint across the slab
    rows = []
    wet_at = pressed_at = None  # (t, mean rho / rho0 in the first spacing)
    print("t_s  tip_m  depth at tip / +2 / +4 / +8 dp (m)  speed at tip (m/s)  max p (kPa)  "
          "rho/rho0 at tip  held / in the first dp")
    for t, path in frames_of(args.out_dir):
        bins = profile(read_vtp(path), args.dp, args.face_x, args.z, args.half_width, args.reach,
                       args.top)
        depth = [b[0] * args.dp ** 3 / area for b in bins]
        for n, b in enumerate(bins):
            rows.append((t, (n + 0.5) * args.dp, depth[n], b[1], b[2] / b[0] if b[0] else 0.0,
                         b[3], b[4], b[5] / b[0] / args.rho0 if b[0] else 0.0))
        first = bins[0]
        if first[0] and wet_at is None:
            wet_at = (t, first[5] / first[0] / args.rho0)
        if first[0] and first[3] > 0 and pressed_at is None:
            pressed_at = (t, first[5] / first[0] / args.rho0)
        wet = [n for n, b in enumerate(bins) if b[0] > 0]
        if not wet:
            print(f"{t:.4f}  dry")
            continue
        tip = wet[0]

        def at(n):
            return depth[n] if n < len(depth) else float("nan")

        print(f"{t:.4f}  {tip * args.dp:.4f}  {at(tip):.4f} {at(tip + 2):.4f} {at(tip + 4):.4f} "
              f"{at(tip + 8):.4f}  {bins[tip][2] / bins[tip][0]:.2f}  "
              f"{max(b[3] for b in bins) / 1000:.1f}  {bins[tip][5] / bins[tip][0] / args.rho0:.3f}  "
              f"{bins[0][4]}/{bins[0][0]}")
    for what, at_t in (("water within one spacing of the face", wet_at),
                       ("pressure there", pressed_at)):
        if at_t is None:
            print(f"first {what}: none")
        else:
            print(f"first {what}: t = {at_t[0]:.4f} s, mean rho/rho0 there {at_t[1]:.3f}")
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["t_s", "distance_m", "depth_m", "top_y_m", "speed_to_face_m_s",
                        "max_pressure_pa", "held_by_contact", "density_over_rho0"])
            w.writerows(rows)


if __name__ == "__main__":
    main()
