"""Tests of the device-side helpers of the benchmarks (bench/README.md, "Martin & Moyce on one
H100"): bench/partcsv_extremes.sh leaves bench/peer_compare.py's Martin & Moyce front exactly as
it was, bench/vtp_leaders.py finds the leading particle of each VTK frame and follows it, and
bench/impact_front.py measures the tongue in front of a face (docs/validation.md)."""

import io
import os
import random
import struct
import subprocess
import sys
import tempfile
import unittest
from contextlib import redirect_stdout

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "bench"))
import impact_front  # noqa: E402
import peer_compare as pc  # noqa: E402
import vtp_leaders  # noqa: E402

HEADER = ("Pos.x [m];Pos.y [m];Pos.z [m];Idp;Vel.x [m/s];Vel.y [m/s];Vel.z [m/s];"
          "Rho [kg/m^3];Type;\n")


class PartCsvExtremesTest(unittest.TestCase):
    def test_the_front_is_unchanged_and_only_two_fluid_rows_stay(self):
        with tempfile.TemporaryDirectory() as root:
            os.makedirs(os.path.join(root, "data"))
            with open(os.path.join(root, "Run.out"), "w") as f:
                f.write("**2D-Simulation parameters:\nDp=0.001\nKernelH=0.0014\nTimePart=0.002\n")
            rng = random.Random(7)
            for k in range(5):
                with open(os.path.join(root, "data", f"PartCsv_{k:04d}.csv"), "w") as f:
                    f.write(HEADER)
                    f.write("9.0;0;0;0;0;0;0;1000;0;\n")  # a wall particle beyond the fluid
                    for i in range(200):
                        x = rng.uniform(0.01, 0.05 + 0.01 * k)
                        f.write(f"{x!r};{rng.random()!r};0;{i + 1};0;0;0;1000;3;\n")
            before = pc.read_peer_front(root)
            subprocess.run([os.path.join(ROOT, "bench", "partcsv_extremes.sh"), root], check=True)
            after = pc.read_peer_front(root)
            self.assertEqual(list(before[0]), list(after[0]))
            self.assertEqual(list(before[1]), list(after[1]))
            self.assertEqual(before[2:], after[2:])
            with open(os.path.join(root, "data", "PartCsv_0003.csv")) as f:
                lines = f.read().splitlines()
            self.assertEqual(len(lines), 3)  # the header, the back and the front particle

    def test_a_directory_without_parts_is_an_error(self):
        with tempfile.TemporaryDirectory() as root:
            proc = subprocess.run([os.path.join(ROOT, "bench", "partcsv_extremes.sh"), root],
                                  capture_output=True, text=True)
            self.assertEqual(proc.returncode, 2)
            self.assertIn("no PartCsv", proc.stderr)


def write_vtp(path, ids, positions, velocities, densities):
    """A .vtp as the project's writer lays it out: raw appended arrays after a UInt64 count."""
    arrays = [("UInt32", "id", 1, struct.pack(f"<{len(ids)}I", *ids)),
              ("Float32", "velocity", 3, struct.pack(f"<{len(velocities)}f", *velocities)),
              ("Float32", "density", 1, struct.pack(f"<{len(densities)}f", *densities)),
              ("Float32", "pressure", 1, struct.pack(f"<{len(ids)}f", *([0.0] * len(ids)))),
              ("Float32", "position", 3, struct.pack(f"<{len(positions)}f", *positions))]
    head, blob = [], b""
    for kind, name, components, data in arrays:
        comp = f' NumberOfComponents="{components}"' if components > 1 else ""
        head.append(f'<DataArray type="{kind}" Name="{name}"{comp} format="appended" '
                    f'offset="{len(blob)}"/>')
        blob += struct.pack("<Q", len(data)) + data
    with open(path, "wb") as f:
        f.write(("<VTKFile><PolyData><Piece>" + "".join(head) +
                 "</Piece></PolyData>\n<AppendedData encoding=\"raw\">\n _").encode())
        f.write(blob + b"\n</AppendedData></VTKFile>\n")


class VtpLeadersTest(unittest.TestCase):
    def test_leaders_and_the_last_leaders_history(self):
        with tempfile.TemporaryDirectory() as root:
            os.makedirs(os.path.join(root, "frames"))
            # Particle 7 starts behind particle 3 and overtakes it in the second frame.
            for n, (x3, x7) in enumerate([(0.5, 0.2), (0.6, 0.9)]):
                write_vtp(os.path.join(root, "frames", f"frame_{n:06d}.vtp"), [3, 7],
                          [x3, 0, 0, x7, 0.1, 0], [0] * 6, [1000 + n, 700])
            out = io.StringIO()
            with redirect_stdout(out):
                vtp_leaders.main([root])
            lines = out.getvalue().splitlines()
            self.assertIn("rho min/max 700.0 1000.0 | lead: id 3 x 0.50000", lines[0])
            self.assertIn("rho min/max 700.0 1001.0 | lead: id 7 x 0.90000", lines[1])
            self.assertEqual(lines[2], "history of id 7")
            self.assertIn("0 id 7 x 0.20000", lines[3])
            self.assertIn("1 id 7 x 0.90000", lines[4])

    def test_no_frames_names_the_directory(self):
        with tempfile.TemporaryDirectory() as root:
            with self.assertRaises(SystemExit) as e:
                vtp_leaders.main([root])
            self.assertIn("no .vtp files", str(e.exception.code))


class ImpactFrontTest(unittest.TestCase):
    def test_a_wedge_tongue_reads_its_tip_depth_speed_and_pressure(self):
        dp, face, half = 0.01, 0.8, 0.02
        with tempfile.TemporaryDirectory() as root:
            os.makedirs(os.path.join(root, "frames"))
            # A wedge: one layer at the tip (3 dp from the face), one more per spacing behind it,
            # 4 particles across the slab; moving at 3 m/s towards -x. One particle outside the
            # slab (z), one behind the face (x < face) and one above its top must not count.
            ids, pos, vel, p = [], [], [], []
            for n in range(5):
                for layer in range(n + 1):
                    for across in range(4):
                        ids.append(len(ids))
                        pos += [face + (3 + n + 0.5) * dp, (layer + 0.5) * dp,
                                0.5 - half + (across + 0.5) * dp]
                        vel += [-3.0, 0.0, 0.0]
                        p.append(1000.0 * n)
            for x, y, z in ((face + 0.035, 0.005, 0.7), (face - 0.01, 0.005, 0.5),
                            (face + 0.035, 0.2, 0.5)):
                ids.append(len(ids))
                pos += [x, y, z]
                vel += [-9.0, 0.0, 0.0]
                p.append(1e6)
            write_vtp(os.path.join(root, "frames", "frame_000000.vtp"), ids, pos, vel,
                      [1000.0] * len(ids))
            # write_vtp's arrays hold zero pressure: put this test's pressures in instead.
            frame = vtp_leaders.read_vtp(os.path.join(root, "frames", "frame_000000.vtp"))
            frame["pressure"] = p
            with open(os.path.join(root, "frames.pvd"), "w") as f:
                f.write('<VTKFile><Collection>\n<DataSet timestep="0.41" group="" part="0" '
                        'file="frames/frame_000000.vtp"/>\n</Collection></VTKFile>\n')
            bins = impact_front.profile(frame, dp, face, 0.5, half, 0.1, top=0.1)
            self.assertEqual([b[0] for b in bins[:9]], [0, 0, 0, 4, 8, 12, 16, 20, 0])
            self.assertEqual(sum(b[4] for b in bins), 0)  # the wedge moves: none is held
            self.assertAlmostEqual(bins[3][2] / bins[3][0], 3.0)
            self.assertEqual(bins[7][3], 4000.0)
            self.assertAlmostEqual(bins[5][1], 2.5 * dp, places=6)
            out = io.StringIO()
            csv_path = os.path.join(root, "front.csv")
            with redirect_stdout(out):
                impact_front.main([root, "--dp", str(dp), "--face-x", str(face), "--z", "0.5",
                                   "--half-width", str(half), "--reach", "0.1", "--top", "0.1",
                                   "--csv",
                                   csv_path])
            row = out.getvalue().splitlines()[1].split()
            self.assertEqual(row[0], "0.4100")
            self.assertEqual(row[1], "0.0300")  # the tip, 3 spacings from the face
            # Depth = count dp^3 / (dp 2 half): one layer at the tip, 3 and 5 behind it.
            self.assertEqual(row[2:5], ["0.0100", "0.0300", "0.0500"])
            self.assertEqual(row[8], "1.000")  # rho / rho0 at the tip: write_vtp's 1000 kg/m^3
            # The wedge's tip is 3 spacings away: no water within one spacing of the face.
            self.assertIn("first water within one spacing of the face: none", out.getvalue())
            with open(csv_path) as f:
                self.assertEqual(len(f.read().splitlines()), 1 + 10)

    def test_counts_the_particles_the_wall_contact_holds(self):
        # Two particles at the contact's limit, 0.2 dp from the face, not moving towards it
        # (held); one there moving towards it and one a little farther, still (not held).
        dp, face = 0.01, 0.8
        frame = {"id": [0, 1, 2, 3],
                 "position": [face + 0.2 * dp, 0.01, 0.5, face + 0.2 * dp, 0.02, 0.5,
                              face + 0.2 * dp, 0.03, 0.5, face + 0.5 * dp, 0.04, 0.5],
                 "velocity": [0.0, 0.5, 0.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                 "pressure": [500.0, 600.0, 700.0, 800.0],
                 "density": [800.0, 900.0, 1000.0, 1100.0]}
        bins = impact_front.profile(frame, dp, face, 0.5, 0.02, 0.05)
        self.assertEqual(bins[0][0], 4)
        self.assertEqual(bins[0][4], 2)
        self.assertAlmostEqual(bins[0][5] / bins[0][0], 950.0)  # the mean density

    def test_no_series_names_the_directory(self):
        with tempfile.TemporaryDirectory() as root:
            with self.assertRaises(SystemExit) as e:
                impact_front.main([root, "--dp", "0.01"])
            self.assertIn("no frames.pvd", str(e.exception.code))


if __name__ == "__main__":
    unittest.main()
