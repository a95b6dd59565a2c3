#!/usr/bin/env python3
"""The Martin & Moyce slab's spurious motion across the slab (z), frame by frame.

The dam-break validation case is a 3D slab a few particles thick standing for a 2D flow, so
every velocity along z is numerical. At a/120 it grows from the compressed bottom of the column
until particles are shot out of the surge (docs/validation.md, "The dam break against the
converged SPH front"). Two steps:

  bench/slab_noise.py scene SPACING LAYERS OUT.json [--periodic]
      writes the validation scene (scenes/validation/dam_break_martin_moyce.json) at SPACING m,
      LAYERS particles thick (free-slip side walls, or periodic across z), probes every 2 ms;
  bench/slab_noise.py frames RUN_DIR
      reads RUN_DIR/frames/*.vtp (`dysa run ... --out RUN_DIR --vtk-every N`) and prints per
      frame: rms v_z, rms in-plane speed, their ratio, the largest speed, the density range and
      the front's x.

For example (a/120 = 0.00047625 m; add --set artificial_viscosity=0.01 to compare):

  bench/slab_noise.py scene 0.00047625 4 /tmp/a120.json
  build/release/clients/cli/dysa run /tmp/a120.json --end-time 0.05 --device cuda \\
      --vtk-every 3 --out /tmp/a120
  bench/slab_noise.py frames /tmp/a120

Plain Python (no numpy), so that it runs on the device machine too.
"""
import glob
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vtp_leaders import read_vtp  # noqa: E402

SCENE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes", "validation",
                     "dam_break_martin_moyce.json")


def write_scene(spacing, layers, out, periodic):
    with open(SCENE) as f:
        scene = json.load(f)
    thickness = layers * spacing
    scene["domain"]["max"][2] = thickness
    if periodic:
        scene["domain"]["periodic"] = [False, False, True]
    for block in scene["fluid_blocks"]:
        block["center"][2], block["size"][2] = thickness / 2, thickness
    scene["params"]["particle_spacing"] = spacing
    scene["probe_interval"] = 0.002
    with open(out, "w") as f:
        json.dump(scene, f, indent=1)


def print_frames(run_dir):
    paths = sorted(glob.glob(os.path.join(run_dir, "frames", "*.vtp")))
    if not paths:
        sys.exit(f"slab_noise.py: no {run_dir}/frames/*.vtp (run dysa run with --vtk-every)")
    for path in paths:
        frame = read_vtp(path)
        x, v, rho = frame["position"], frame["velocity"], frame["density"]
        n = len(rho)
        sum_z = sum_xy = fastest = front = 0.0
        for k in range(n):
            vx, vy, vz = v[3 * k], v[3 * k + 1], v[3 * k + 2]
            sum_z += vz * vz
            sum_xy += vx * vx + vy * vy
            fastest = max(fastest, vx * vx + vy * vy + vz * vz)
            front = max(front, x[3 * k])
        print("%s n %d rms_vz %.4f rms_vxy %.4f ratio %.3f vmax %.2f rho %.0f..%.0f xmax %.4f" % (
            os.path.basename(path), n, math.sqrt(sum_z / n), math.sqrt(sum_xy / n),
            math.sqrt(sum_z / max(sum_xy, 1e-30)), math.sqrt(fastest), min(rho), max(rho), front))


def main(argv):
    if len(argv) >= 5 and argv[1] == "scene":
        write_scene(float(argv[2]), int(argv[3]), argv[4], "--periodic" in argv[5:])
    elif len(argv) == 3 and argv[1] == "frames":
        print_frames(argv[2])
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main(sys.argv)
