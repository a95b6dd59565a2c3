#!/usr/bin/python3
"""Parameter sweep: how much kinetic energy the fluid keeps for several viscosities.

For each value: pause, set the parameter, reset the fluid, then step N frames one at a time,
reading every frame from the frame stream, and compute the mean kinetic energy per particle
per unit mass, 0.5 |v|^2 (J/kg = m^2/s^2), from the streamed velocities. Prints a table and
writes it as CSV (and, with --series, the energy of every frame). The parameter is set back to
its first value at the end and the simulation is left paused.

    /usr/bin/python3 clients/python/examples/param_sweep.py --server 127.0.0.1:50051 \
        --values 0.0005,0.001,0.005,0.01 --frames 120 --csv sweep.csv

Stepping one frame per call (rather than resuming) makes the stream deliver every frame: a
frame stream skips frames for a reader that falls behind a running simulation.
"""

from __future__ import annotations

import argparse
import csv
import sys
import threading
import time
from pathlib import Path
from typing import List, Optional

import numpy as np

try:
    import dysa  # noqa: F401
except ImportError:  # run from a checkout without PYTHONPATH: the package next to this file
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

try:
    from dysa.client import Client, DysaError
    from dysa.codec import Frame
except ImportError as _error:  # the stubs are not built, or not /usr/bin/python3
    sys.exit("param_sweep: %s" % _error)


class FrameCollector:
    """Reads a frame stream on a background thread, so the main thread can wait for a given
    frame with a timeout (iterating a stream blocks without one)."""

    def __init__(self, stream) -> None:
        self._stream = stream
        self._cond = threading.Condition()
        self._latest: Optional[Frame] = None
        self._error: Optional[BaseException] = None
        self._done = False
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            for frame in self._stream:
                with self._cond:
                    self._latest = frame
                    self._cond.notify_all()
        except BaseException as error:  # noqa: BLE001 - handed to the waiting thread
            with self._cond:
                self._error = error
        finally:
            with self._cond:
                self._done = True
                self._cond.notify_all()

    def wait_for(self, sim_frame: int, timeout: float) -> Frame:
        """The first frame numbered sim_frame or later (frames since the last reset)."""
        def ready() -> bool:
            return self._done or (self._latest is not None
                                  and self._latest.sim_frame >= sim_frame)
        with self._cond:
            if not self._cond.wait_for(ready, timeout):
                raise TimeoutError("frame %d did not arrive within %g s" % (sim_frame, timeout))
            if self._latest is not None and self._latest.sim_frame >= sim_frame:
                return self._latest
            if self._error is not None:
                raise self._error
            raise RuntimeError("the frame stream ended before frame %d" % sim_frame)

    def close(self) -> None:
        """Ends the stream and the thread."""
        self._stream.close()
        self._thread.join(timeout=10)


def kinetic_energy(frame: Frame) -> float:
    """Mean 0.5 |v|^2 over the frame's particles, J/kg (from velocity, else speed)."""
    if frame.velocities is not None:
        v2 = np.sum(frame.velocities.astype(np.float64) ** 2, axis=1)
    elif frame.speed is not None:
        v2 = frame.speed.astype(np.float64) ** 2
    else:
        raise ValueError("the frame has neither velocity nor speed")
    return float(0.5 * v2.mean()) if v2.size else 0.0


def run_one(client: Client, param: str, value: float, frames: int, stride: int,
            timeout: float) -> List[tuple]:
    """Resets with param = value and steps `frames` frames; returns (frame, time s, KE J/kg)
    of each."""
    client.pause()
    client.set_params({param: value})
    client.reset()
    before = client.pause().status.subscribers  # step from a paused state, whatever reset did
    stream = client.frames(fields=("positions", "velocity"), stride=stride)
    collector = FrameCollector(stream)
    # The stream opens asynchronously: a frame simulated before the server counts this
    # subscriber would never be sent to it, and waiting for it would time out.
    wait_until = time.monotonic() + timeout
    while client.status().subscribers <= before and time.monotonic() < wait_until:
        time.sleep(0.01)
    try:
        rows = []
        for _ in range(frames):
            moved = client.step(1)
            frame = collector.wait_for(moved.status.frame, timeout)
            rows.append((frame.sim_frame, frame.time, kinetic_energy(frame)))
        return rows
    finally:
        collector.close()


def main(argv: Optional[List[str]] = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--server", default="127.0.0.1:50051", help="HOST:PORT of dysa-server")
    parser.add_argument("--token-file", help="file holding the server's token")
    parser.add_argument("--param", default="viscosity", help="parameter to sweep")
    parser.add_argument("--values", default="0.0005,0.001,0.005,0.01",
                        help="comma-separated values, in the parameter's unit")
    parser.add_argument("--frames", type=int, default=120, help="frames per value")
    parser.add_argument("--stride", type=int, default=1,
                        help="use every n-th particle (faster for big scenes)")
    parser.add_argument("--csv", default="param_sweep.csv", help="summary CSV to write")
    parser.add_argument("--series", help="also write every frame's energy to this CSV")
    parser.add_argument("--timeout", type=float, default=60.0,
                        help="seconds to wait for one frame")
    args = parser.parse_args(argv)
    try:
        values = [float(v) for v in args.values.split(",") if v.strip()]
    except ValueError:
        parser.error("--values: comma-separated numbers expected, got %r" % args.values)
    if not values or args.frames < 1:
        parser.error("need at least one value and --frames >= 1")
    token = Path(args.token_file).read_text().strip() if args.token_file else None

    with Client(args.server, token=token) as client:
        try:
            info = client.params()
            if args.param not in info:
                parser.error("unknown parameter %r; known: %s" % (args.param, ", ".join(info)))
            original = info[args.param]
            unit = original.unit or "-"
            status = client.status()
            print("scene %s, %d particles, %d frames per value (stride %d)"
                  % (status.scene, status.particles, args.frames, args.stride))
            summary, series = [], []
            try:
                for value in values:
                    rows = run_one(client, args.param, value, args.frames, args.stride,
                                   args.timeout)
                    energies = np.array([r[2] for r in rows])
                    summary.append((value, len(rows), rows[-1][1], float(energies.mean()),
                                    float(energies[-1])))
                    series += [(value,) + r for r in rows]
            finally:
                client.pause()
                client.set_params({args.param: original.value})
        except DysaError as error:
            print("param_sweep: %s" % error, file=sys.stderr)
            return 1

    header = ("%s (%s)" % (args.param, unit), "frames", "time (s)", "mean KE (J/kg)",
              "final KE (J/kg)")
    print("%-20s %7s %9s %16s %16s" % header)
    for value, n, t, mean, final in summary:
        print("%-20g %7d %9.4f %16.6g %16.6g" % (value, n, t, mean, final))
    with open(args.csv, "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow([args.param, "frames", "time_s", "mean_ke_j_per_kg",
                         "final_ke_j_per_kg"])
        writer.writerows(summary)
    print("wrote %s" % args.csv)
    if args.series:
        with open(args.series, "w", newline="", encoding="utf-8") as f:
            writer = csv.writer(f)
            writer.writerow([args.param, "frame", "time_s", "ke_j_per_kg"])
            writer.writerows(series)
        print("wrote %s" % args.series)
    return 0


if __name__ == "__main__":
    sys.exit(main())
