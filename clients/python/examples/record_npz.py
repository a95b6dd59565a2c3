#!/usr/bin/python3
"""Records particle frames from a running dysa-server into a numpy .npz file.

    /usr/bin/python3 clients/python/examples/record_npz.py --server 127.0.0.1:50051 \
        --frames 100 --out run.npz --resume

The file holds, for F recorded frames of N particles (every `stride`-th particle by id):
  positions (F, N, 3) float32, m      speed (F, N) float32, m/s (when streamed)
  velocity (F, N, 3) float32, m/s      density (F, N) float32, kg/m^3 (when requested)
  time (F,) float64, s                 step (F,) int64: solver step
  frame (F,) int64: frame since the last reset
  frames_skipped (F,) int64: frames the stream skipped before each recorded one
  stride () int64, and position_error (F, 3) float64, m: the quantisation error bound per axis.

Frames come as the server simulates them: a paused simulation sends none (use --resume, or
step it from elsewhere), and a reader that falls behind skips frames (frames_skipped; lower
--max-fps or raise --stride to keep up). Stops after --frames frames, after --duration seconds,
or on Ctrl-C, and writes what it has (with the particle count of the first frame: frames of
another count, after a scene change, end the recording).
"""

from __future__ import annotations

import argparse
import sys
import threading
from pathlib import Path
from typing import Dict, List, Optional

import numpy as np

try:
    import dysa  # noqa: F401
except ImportError:  # run from a checkout without PYTHONPATH: the package next to this file
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

try:
    from dysa.client import Client, DysaError
except ImportError as _error:  # the stubs are not built, or not /usr/bin/python3
    sys.exit("record_npz: %s" % _error)


def main(argv: Optional[List[str]] = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--server", default="127.0.0.1:50051", help="HOST:PORT of dysa-server")
    parser.add_argument("--token-file", help="file holding the server's token")
    parser.add_argument("--frames", type=int, default=100, help="frames to record")
    parser.add_argument("--out", default="frames.npz", help=".npz file to write")
    parser.add_argument("--fields", default="positions,speed",
                        help="comma-separated: positions, speed, velocity, density")
    parser.add_argument("--max-fps", type=float, default=0.0,
                        help="frames per wall second at most (0: every frame)")
    parser.add_argument("--stride", type=int, default=1, help="record every n-th particle")
    parser.add_argument("--position-bits", type=int, default=16, help="bits per axis, 1..24")
    parser.add_argument("--resume", action="store_true", help="resume the simulation first")
    parser.add_argument("--duration", type=float, default=0.0,
                        help="stop after this many wall seconds (0: no limit)")
    args = parser.parse_args(argv)
    if args.frames < 1:
        parser.error("--frames must be >= 1")
    fields = tuple(f.strip() for f in args.fields.split(",") if f.strip())
    token = Path(args.token_file).read_text().strip() if args.token_file else None

    data: Dict[str, list] = {k: [] for k in ("positions", "speed", "velocity", "density",
                                             "time", "step", "frame", "frames_skipped",
                                             "position_error")}
    stride = args.stride
    with Client(args.server, token=token) as client:
        try:
            if args.resume:
                client.resume()
            stream = client.frames(fields=fields, max_fps=args.max_fps, stride=args.stride,
                                   position_bits=args.position_bits, limit=args.frames)
        except (DysaError, ValueError) as error:
            print("record_npz: %s" % error, file=sys.stderr)
            return 1
        # close() from a timer thread makes the blocked iteration below stop cleanly.
        timer = None
        if args.duration > 0:
            timer = threading.Timer(args.duration, stream.close)
            timer.daemon = True
            timer.start()
        try:
            for frame in stream:
                if data["positions"] and frame.count != data["positions"][0].shape[0]:
                    print("record_npz: the particle count changed (%d -> %d); stopping"
                          % (data["positions"][0].shape[0], frame.count), file=sys.stderr)
                    break
                stride = frame.stride
                data["positions"].append(frame.positions)
                data["speed"].append(frame.speed)
                data["velocity"].append(frame.velocities)
                data["density"].append(frame.densities)
                data["time"].append(frame.time)
                data["step"].append(frame.step)
                data["frame"].append(frame.sim_frame)
                data["frames_skipped"].append(frame.frames_skipped)
                data["position_error"].append(frame.position_error)
        except KeyboardInterrupt:
            pass
        except DysaError as error:
            # E.g. the server shut down: keep what was recorded.
            print("record_npz: %s" % error, file=sys.stderr)
        finally:
            stream.close()
            if timer is not None:
                timer.cancel()

    if not data["positions"]:
        print("record_npz: no frame received (is the simulation paused? try --resume)",
              file=sys.stderr)
        return 1
    arrays = {
        "positions": np.stack(data["positions"]),
        "time": np.array(data["time"], np.float64),
        "step": np.array(data["step"], np.int64),
        "frame": np.array(data["frame"], np.int64),
        "frames_skipped": np.array(data["frames_skipped"], np.int64),
        "position_error": np.array(data["position_error"], np.float64),
        "stride": np.array(stride, np.int64),
    }
    for name in ("speed", "velocity", "density"):
        if all(a is not None for a in data[name]):
            arrays[name] = np.stack(data[name])
    np.savez_compressed(args.out, **arrays)
    print("record_npz: %d frames of %d particles (t = %.4f .. %.4f s) -> %s"
          % (len(data["time"]), arrays["positions"].shape[1], arrays["time"][0],
             arrays["time"][-1], args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
