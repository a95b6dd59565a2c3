#!/usr/bin/env python3
"""The leading particles of a `dysa run --vtk-every N` output, frame by frame, and the history of
the last frame's leader: how an outlier ahead of a front came to be (bench/README.md, "Martin &
Moyce on one H100").

  bench/vtp_leaders.py OUT_DIR [--axis x|y|z]

Reads OUT_DIR/frames/*.vtp (the project's own VTK writer: raw appended arrays, each after its
UInt64 byte count). Plain Python, no numpy: it runs on the GPU box, next to the frames, so that
only its text comes back. Prints per frame the smallest and largest density and the particle
farthest along the axis; then that frame-by-frame record of the last frame's leader.
"""

import argparse
import array
import glob
import os
import re
import struct
import sys

_ARRAY = re.compile(r'<DataArray type="(\w+)" Name="(\w+)"(?: NumberOfComponents="\d")? '
                    r'format="appended" offset="(\d+)"')
_TYPES = {"UInt32": "I", "Float32": "f", "Int32": "i"}


def read_vtp(path):
    """The named arrays of one .vtp file (flat: xyz triples for vectors)."""
    data = open(path, "rb").read()
    appended = data.index(b"<AppendedData")
    head = data[:appended].decode()
    start = data.index(b"_", appended) + 1
    arrays = {}
    for kind, name, offset in _ARRAY.findall(head):
        at = start + int(offset)
        size = struct.unpack("<Q", data[at:at + 8])[0]
        values = array.array(_TYPES[kind])
        values.frombytes(data[at + 8:at + 8 + size])
        arrays[name] = values
    for needed in ("id", "position", "velocity", "density", "pressure"):
        if needed not in arrays:
            sys.exit(f"{path}: no '{needed}' array")
    return arrays


def describe(frame, k):
    x, v = frame["position"], frame["velocity"]
    return ("id %d x %.5f y %.5f z %.5f v %.3f %.3f %.3f rho %.1f p %.0f" %
            (frame["id"][k], x[3 * k], x[3 * k + 1], x[3 * k + 2], v[3 * k], v[3 * k + 1],
             v[3 * k + 2], frame["density"][k], frame["pressure"][k]))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out_dir")
    parser.add_argument("--axis", choices="xyz", default="x")
    args = parser.parse_args(argv)
    paths = sorted(glob.glob(os.path.join(args.out_dir, "frames", "*.vtp")))
    if not paths:
        sys.exit(f"{args.out_dir}/frames: no .vtp files (dysa run --vtk-every N --out DIR)")
    axis = "xyz".index(args.axis)
    frames = [read_vtp(p) for p in paths]

    def leader(frame):
        x = frame["position"]
        return max(range(len(frame["id"])), key=lambda k: x[3 * k + axis])

    for n, frame in enumerate(frames):
        rho = frame["density"]
        print(f"frame {n} rho min/max {min(rho):.1f} {max(rho):.1f} | lead: "
              f"{describe(frame, leader(frame))}")
    last = frames[-1]
    pid = last["id"][leader(last)]
    print(f"history of id {pid}")
    for n, frame in enumerate(frames):
        print(f"  {n} {describe(frame, list(frame['id']).index(pid))}")


if __name__ == "__main__":
    main()
