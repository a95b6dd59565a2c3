"""Tests of bench/peer_compare.py (the DualSPHysics comparison, bench/README.md "Against
DualSPHysics") on synthetic gauge files whose arrivals, peaks and errors are known exactly.

Run: /usr/bin/python3 tests/python/test_peer_compare.py [unittest args]
(ctest: python_peer_compare_test).
"""

import csv
import math
import os
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

import numpy as np

_BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path.insert(0, str(_BENCH))
import peer_compare as pc  # noqa: E402

B, RHO0 = 300000.0, 1000.0  # the synthetic Run.out's CteB and RhopZero
A, G = 0.05715, 9.81


def rho_of(p):
    """The density a DualSPHysics mesh gauge reports for pressure p (its EOS inverted)."""
    return RHO0 * (1.0 + p / B) ** (1.0 / 7.0)


def write_run_out(directory, dp, kernel_h, time_part=0.01, two_d=False):
    with open(os.path.join(directory, "Run.out"), "w") as f:
        f.write(f"**{'2' if two_d else '3'}D-Simulation parameters:\n")
        f.write(f"Dp={dp}\nKernelH={kernel_h}  (CoefficientH=1; H/Dp=1.73205)\n")
        f.write(f"CteB={B}\nGamma=7\nRhopZero={RHO0}\nTimePart={time_part}\n")


def write_mesh(path, times, columns, npt1, npt2, ref, vec1, vec2):
    """A GaugesMesh_*_Rhop.csv: every point 1000 kg/m^3 (p = 0) but `columns` {(i, j): p(t)}."""
    with open(path, "w") as f:
        f.write("Format;DataName;DataUnits;DataType;Data12;Npt1;Npt2;Npt3;PtRef.x [m];PtRef.y;"
                "PtRef.z;Vec1.x [m];Vec1.y;Vec1.z;Vec2.x;Vec2.y;Vec2.z;Vec3.x;Vec3.y;Vec3.z;"
                "DirDat.x;DirDat.y;DirDat.z\n")
        f.write(f"JMeshTDatas-200817;Rhop; [kg/m^3];float;false;{npt1};{npt2};1;{ref[0]};"
                f"{ref[1]};{ref[2]};{vec1[0]};{vec1[1]};{vec1[2]};{vec2[0]};{vec2[1]};{vec2[2]};"
                "0;0;0;1;0;0\n")
        names = [(i, j) for j in range(npt2) for i in range(npt1)]
        f.write("time [s];" + ";".join(f"v({i}:{j}:0)" for i, j in names) + "\n")
        for k, t in enumerate(times):
            vals = [repr(rho_of(columns[n][k])) if n in columns else "1000" for n in names]
            f.write(f"{t:.6f};" + ";".join(vals) + "\n")


def write_swl(path, times, heights, z0=0.01):
    with open(path, "w") as f:
        f.write("time [s];swlx [m];swly [m];swlz [m];pos0x [m];pos0y [m];pos0z [m];pos2x [m];"
                "pos2y [m];pos2z [m]\n")
        for t, h in zip(times, heights):
            f.write(f"{t:.6f};0.5;0.5;{h};0.5;0.5;{z0};0.5;0.5;1\n")


def plateau(times, start, end, value, spikes=()):
    p = np.where((times >= start - 1e-9) & (times <= end + 1e-9), value, 0.0)
    for t, v in spikes:
        p[np.argmin(np.abs(times - t))] = v
    return p


class Fixture:
    """A fake repository (MARIN heights, Martin & Moyce table), a DualSPHysics output directory
    and a project step series for SPHERIC Test 2, all synthetic."""

    def __init__(self, root):
        self.root = root
        self.repo = os.path.join(root, "repo")
        val = os.path.join(self.repo, "server", "validation", "data")
        os.makedirs(val)
        # MARIN: every 10 ms to 1 s; H1 and H3 dry, H2 0.1 m, H4 0.5 m.
        with open(os.path.join(val, "spheric_test2_marin_heights.csv"), "w") as f:
            f.write("# synthetic\nt_s,H1_m,H2_m,H3_m,H4_m\n")
            for k in range(101):
                f.write(f"{k / 100:.2f},0,0.1,0,0.5\n")
        with open(os.path.join(val, "dam_break_martin_moyce_1952_front.csv"), "w") as f:
            f.write("# synthetic\nT,Z\n0,1\n1,2\n2,3\n")
        # The peer at dp 0.01: the face's particle layer at round(0.8245 / 0.01) 0.01 = 0.82,
        # 1.5 h = 0.0259815 from it: the point nearest x = 0.8459815 on the 2.5 mm mesh from
        # 0.8245 is index 9. Pressures every 0.3 ms (a 1 ms window holds 3 samples, 5 ms 17).
        self.peer = os.path.join(root, "peer")
        os.makedirs(self.peer)
        write_run_out(self.peer, 0.01, 0.017321)
        t = np.round(np.arange(2668) * 0.0003, 7)  # to 0.8001 s
        p1 = plateau(t, 0.4101, 0.5, 3000.0,
                     [(0.42, 6000.0), (0.4203, 12000.0), (0.4206, 9000.0), (0.47, 50000.0)])
        p2 = plateau(t, 0.4302, 0.5, 1200.0)
        top = plateau(t, 0.45, 0.46, 700.0)  # P5: x index 3; layer 0.16 + 1.5 h: z index 10
        write_mesh(os.path.join(self.peer, "GaugesMesh_PFront_Rhop.csv"), t,
                   {(9, 0): p1, (9, 1): p2, (0, 0): np.full(t.size, 99999.0)}, 25, 4,
                   (0.8245, 0.471, 0.021), (0.0025, 0, 0), (0, 0, 0.04))
        write_mesh(os.path.join(self.peer, "GaugesMesh_PTop_Rhop.csv"), t, {(3, 10): top}, 4, 25,
                   (0.6835, 0.471, 0.161), (0.04, 0, 0), (0, 0, 0.0025))
        ts = np.round(np.arange(802) * 0.001, 6)  # 1 kHz to 0.801 s
        write_swl(os.path.join(self.peer, "GaugesSWL_H1.csv"), ts, np.full(ts.size, 0.01))
        write_swl(os.path.join(self.peer, "GaugesSWL_H2.csv"), ts, np.full(ts.size, 0.111))
        write_swl(os.path.join(self.peer, "GaugesSWL_H3.csv"), ts,
                  np.where(ts > 0.7005, 0.12, 0.01))
        write_swl(os.path.join(self.peer, "GaugesSWL_H4.csv"), ts, np.full(ts.size, 0.511))
        # The project: every 0.4 ms (3 samples in 1 ms, 13 in 5 ms).
        self.steps = os.path.join(root, "spheric_test2_steps_0.0100.csv")
        tj = np.round(np.arange(2001) * 0.0004, 7)  # to 0.8 s
        pj1 = plateau(tj, 0.402, 0.5, 2000.0, [(0.44, 5000.0), (0.4404, 8000.0), (0.4408, 6500.0)])
        with open(self.steps, "w") as f:
            f.write("t_s,P1_pa,P2_pa,P3_pa,P4_pa,P5_pa,P6_pa,P7_pa,P8_pa,H1_m,H2_m,H3_m,H4_m\n")
            for k, tt in enumerate(tj):
                f.write(f"{tt:.7f},{pj1[k]},0,0,0,0,0,0,0,0,0.1,0,{0.5 - 0.0055}\n")

    def run(self, *extra):
        out = os.path.join(self.root, "out")
        rows = pc.main(["--case", "spheric2", "--tag", "test", "--tmax", "0.8", "--repo",
                        self.repo, "--out", out, "--run", "0.01", self.peer, self.steps,
                        *extra])
        return {r["code"]: r for r in rows}, out


class MovingAverageTest(unittest.TestCase):
    def test_weighted_by_step_length(self):
        # Samples at 0, 1, 3 (s): lengths 0, 1, 2. At t = 1 with a 4 s window, (-1, 3] holds
        # all three: (0 * 100 + 1 * 10 + 2 * 40) / 3 = 30.
        avg = pc.moving_average([0.0, 1.0, 3.0], [100.0, 10.0, 40.0], 4.0)
        self.assertAlmostEqual(avg[1], 30.0, places=12)
        # At t = 0: (-2, 2] holds samples 0 (weight 0) and 1: 10.
        self.assertAlmostEqual(avg[0], 10.0, places=12)

    def test_first_crossing_interpolates(self):
        self.assertAlmostEqual(pc.first_crossing(np.array([0.0, 1.0, 2.0]),
                                                 np.array([0.0, 200.0, 1000.0]), 500.0), 1.375)
        self.assertTrue(math.isnan(pc.first_crossing(np.array([0.0, 1.0]),
                                                     np.array([0.0, 499.0]), 500.0)))


    def test_height_error_rows(self):
        # A series ending at 0.699 s still reads the row at 0.7 s (within 2 ms), not 0.71 s.
        ref_t = np.array([0.0, 0.7, 0.71])
        rms, last = pc.height_error(np.array([0.0, 0.699]), np.array([0.1, 0.2]), ref_t,
                                    np.array([0.1, 0.1, 0.1]), 0.8)
        self.assertAlmostEqual(rms, math.sqrt(0.1 ** 2 / 2) / 0.55, places=12)
        self.assertEqual(last, 0.7)


class SphericTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.fx = Fixture(self.tmp.name)

    def tearDown(self):
        self.tmp.cleanup()

    def test_peer_measures(self):
        rows, _ = self.fx.run()
        r = rows["dualsphysics"]
        # 1 ms average: 0 at 0.4095, 1000 at 0.4098 (one of 3 samples at 3000): 500 Pa at 0.40965.
        self.assertAlmostEqual(r["P1_arrival_s"], 0.40965, places=9)
        self.assertAlmostEqual(r["P1_arrival_error_s"], 0.40965 - 0.393, places=9)
        # The spike 6, 12, 9 kPa at 0.4200-0.4206: its 1 ms peak (6 + 12 + 9) / 3 at 0.4203;
        # the 50 kPa sample at 0.47 lies outside 0.40-0.46 s.
        self.assertAlmostEqual(r["P1_peak_1ms_pa"], 9000.0, places=5)
        self.assertAlmostEqual(r["P1_peak_1ms_time_s"], 0.4203, places=9)
        # 5 ms: 17 samples, the spike's 3 and 14 of the plateau.
        self.assertAlmostEqual(r["P1_peak_5ms_pa"], (27000.0 + 14 * 3000.0) / 17, places=5)
        # P2: 400 at 0.4299, 800 at 0.4302.
        self.assertAlmostEqual(r["P2_arrival_s"], 0.4299 + 0.25 * 0.0003, places=9)
        self.assertAlmostEqual(r["P2_peak_1ms_pa"], 1200.0, places=5)
        # Heights: H1 dry (the point0 reading counts as 0), H2 and H4 11 mm high, H3 12 cm
        # high from 0.71 s (5 of the 76 rows to 0.75 s, 10 of the 81 to 0.8 s).
        self.assertAlmostEqual(r["H1_rms_to_0.75s"], 0.0, places=12)
        self.assertAlmostEqual(r["H2_rms_to_0.75s"], 0.02, places=9)
        self.assertAlmostEqual(r["H4_rms_to_tmax"], 0.02, places=9)
        self.assertAlmostEqual(r["H3_rms_to_0.75s"], 0.12 * math.sqrt(5 / 76) / 0.55, places=9)
        self.assertAlmostEqual(r["H3_rms_to_tmax"], 0.12 * math.sqrt(10 / 81) / 0.55, places=9)
        self.assertAlmostEqual(r["tmax_s"], 0.8)
        self.assertAlmostEqual(r["early_end_s"], 0.75)
        self.assertIn("1.5h", r["pressure_source"])

    def test_project_measures(self):
        rows, out = self.fx.run()
        r = rows["project"]
        # 1 ms: 0 at 0.4012, 666.7 at 0.4016: 500 Pa at 0.4015.
        self.assertAlmostEqual(r["P1_arrival_s"], 0.4015, places=9)
        self.assertAlmostEqual(r["P1_peak_1ms_pa"], 6500.0, places=5)
        self.assertAlmostEqual(r["P1_peak_1ms_time_s"], 0.4404, places=9)
        self.assertAlmostEqual(r["P1_peak_5ms_pa"], (19500.0 + 10 * 2000.0) / 13, places=5)
        self.assertTrue(math.isnan(r["P2_arrival_s"]))
        self.assertEqual(r["P2_peak_1ms_pa"], 0.0)  # dry: no peak time
        self.assertTrue(math.isnan(r["P2_peak_1ms_time_s"]))
        self.assertAlmostEqual(r["H2_rms_to_0.75s"], 0.0, places=12)
        self.assertAlmostEqual(r["H4_rms_to_0.75s"], 0.01, places=9)
        # The CSV and the PNG exist; the experiment row carries MARIN's record.
        with open(os.path.join(out, "peer_compare_spheric2_test.csv")) as f:
            table = list(csv.DictReader(f))
        self.assertEqual([t["code"] for t in table], ["experiment", "dualsphysics", "project"])
        self.assertEqual(table[0]["P1_arrival_s"], "0.393")
        self.assertEqual(table[0]["P2_peak_1ms_pa"], "8130")
        self.assertEqual(float(table[2]["P1_arrival_s"]), 0.4015)
        self.assertGreater(os.path.getsize(os.path.join(out, "peer_compare_spheric2_test.png")), 0)
        # The converted series: the peer's P5 (top, x index 3, 1.5 h above the top's layer).
        with open(os.path.join(out, "peer_series_spheric2_dualsphysics_0.01_test.csv")) as f:
            series = {row["t_s"]: row for row in csv.DictReader(f)}
        self.assertAlmostEqual(float(series["0.455"]["P5_1ms_pa"]), 700.0, places=3)
        self.assertAlmostEqual(float(series["0.2"]["P5_1ms_pa"]), 0.0, places=3)

    def test_box_force_peaks_of_both_codes(self):
        # The peer's force gauge every 0.1 ms (its forcex negative: the flow pushes towards -x),
        # a 1 ms push of 600 N with one 900 N sample at 0.425 s; the project's file every 0.2 ms
        # with a plateau of 400 N from 0.43 s.
        tf = np.round(np.arange(8001) * 0.0001, 7)
        push = plateau(tf, 0.42, 0.43, 600.0, [(0.425, 900.0), (0.5, 5000.0)])
        with open(os.path.join(self.fx.peer, "GaugesForce_ForceBox.csv"), "w") as f:
            f.write("time [s];force [N];forcex [N];forcey [N];forcez [N]\n")
            for k, t in enumerate(tf):
                f.write(f"{t:.7f};{push[k]};{-push[k]};0;0\n")
        tj = np.round(np.arange(4001) * 0.0002, 7)
        with open(os.path.join(self.tmp.name, "spheric_test2_force_0.0100.csv"), "w") as f:
            f.write("t_s,Fx_n\n")
            for t, v in zip(tj, plateau(tj, 0.43, 0.45, 400.0)):
                f.write(f"{t:.7f},{-v}\n")
        rows, _ = self.fx.run()
        # 1 ms windows that hold the 900 N sample among the 600 N ones: above 600, below 900,
        # within half a window of 0.425 s; the 5 kN at 0.5 s is outside 0.40-0.46 s.
        self.assertGreater(rows["dualsphysics"]["Fx_peak_1ms_n"], 600.0)
        self.assertLess(rows["dualsphysics"]["Fx_peak_1ms_n"], 900.0)
        self.assertLessEqual(abs(rows["dualsphysics"]["Fx_peak_1ms_time_s"] - 0.425), 0.0005 + 1e-9)
        self.assertAlmostEqual(rows["project"]["Fx_peak_1ms_n"], 400.0, places=6)
        # Without the files there is no force: no column value, no error.
        os.remove(os.path.join(self.fx.peer, "GaugesForce_ForceBox.csv"))
        os.remove(os.path.join(self.tmp.name, "spheric_test2_force_0.0100.csv"))
        rows, _ = self.fx.run()
        self.assertNotIn("Fx_peak_1ms_n", rows["project"])

    def test_pareto_pairs_wall_time_with_errors(self):
        out = os.path.join(self.fx.root, "out")
        os.makedirs(out)
        with open(os.path.join(out, "peer_throughput_spheric2_test.csv"), "w") as f:
            f.write("code,case,dp_m,wall_s\ndualsphysics,spheric2,0.01,156\n"
                    "project,spheric2,0.01,40\n")
        self.fx.run()
        with open(os.path.join(out, "pareto_spheric2_test.csv")) as f:
            table = {r["code"]: r for r in csv.DictReader(f)}
        self.assertEqual(float(table["dualsphysics"]["wall_s"]), 156)
        # The peer's 1 ms peak 9 kPa, arrival 0.40965 s; the project's 6.5 kPa, 0.4015 s.
        self.assertAlmostEqual(float(table["dualsphysics"]["P1_peak_1ms_rel_error"]),
                               2240 / 11240, places=5)
        self.assertAlmostEqual(float(table["dualsphysics"]["P1_arrival_error_ms"]), 16.65,
                               places=5)
        self.assertAlmostEqual(float(table["project"]["P1_peak_1ms_rel_error"]), 4740 / 11240,
                               places=5)
        self.assertAlmostEqual(float(table["project"]["H4_rms_to_0.75s"]), 0.01, places=6)
        self.assertGreater(os.path.getsize(os.path.join(out, "pareto_spheric2_test.png")), 0)

    def test_another_project_run_is_measured_alike_with_its_wall_time(self):
        # A second project run (another solver) from its own directory: the same steps, so the
        # same measures, under the code project_dfsph; its wall time comes from the
        # accuracy_spheric_test2.csv accuracy_bench wrote beside the steps.
        other = os.path.join(self.fx.root, "dfsph")
        os.makedirs(other)
        steps = os.path.join(other, "spheric_test2_steps_0.0100.csv")
        Path(steps).write_text(Path(self.fx.steps).read_text())
        Path(os.path.join(other, "accuracy_spheric_test2.csv")).write_text(
            "solver,spacing_m,particles,steps,particle_steps,wall_s\n"
            "dfsph,0.02,1,1,1,3.5\ndfsph,0.01,2,2,4,37.25\n")
        out = os.path.join(self.fx.root, "out")
        os.makedirs(out)
        with open(os.path.join(out, "peer_throughput_spheric2_test.csv"), "w") as f:
            f.write("code,case,dp_m,wall_s\ndualsphysics,spheric2,0.01,156\n"
                    "project,spheric2,0.01,40\n")
        rows, _ = self.fx.run("--project-run", "dfsph", "0.01", steps)
        self.assertAlmostEqual(rows["project_dfsph"]["P1_arrival_s"], 0.4015, places=9)
        self.assertAlmostEqual(rows["project_dfsph"]["P1_peak_1ms_pa"], 6500.0, places=5)
        self.assertIn("dfsph", rows["project_dfsph"]["pressure_source"])
        with open(os.path.join(out, "peer_compare_spheric2_test.csv")) as f:
            codes = [t["code"] for t in csv.DictReader(f)]
        self.assertEqual(codes, ["experiment", "dualsphysics", "project", "project_dfsph"])
        with open(os.path.join(out, "pareto_spheric2_test.csv")) as f:
            table = {r["code"]: r for r in csv.DictReader(f)}
        self.assertEqual(float(table["project_dfsph"]["wall_s"]), 37.25)
        self.assertEqual(float(table["project"]["wall_s"]), 40)
        self.assertTrue(os.path.exists(
            os.path.join(out, "peer_series_spheric2_project_dfsph_0.01_test.csv")))

    def test_project_runs_alone_and_their_errors(self):
        # Without the peer: the project's runs only (no Pareto without a throughput file).
        out = os.path.join(self.fx.root, "alone")
        rows = pc.main(["--case", "spheric2", "--tag", "test", "--tmax", "0.8", "--repo",
                        self.fx.repo, "--out", out, "--project-run", "dfsph", "0.01",
                        self.fx.steps])
        self.assertEqual([r["code"] for r in rows][-1], "project_dfsph")
        self.assertNotIn("dualsphysics", [r["code"] for r in rows])
        for argv, message in (
                (["--case", "spheric2"], "at least one --run"),
                (["--case", "spheric2", "--project-run", "dfsph", "-0.01", self.fx.steps],
                 "--project-run DP '-0.01' must be a positive number"),
                (["--case", "martinmoyce", "--project-run", "dfsph", "0.01", self.fx.steps],
                 "--project-run is for --case spheric2")):
            proc = subprocess.run([sys.executable, str(_BENCH / "peer_compare.py"), "--repo",
                                   self.fx.repo, "--out", out] + argv,
                                  capture_output=True, text=True)
            self.assertEqual(proc.returncode, 2, argv)
            self.assertIn(message, proc.stderr)

    def test_no_pareto_without_throughput(self):
        _, out = self.fx.run()
        self.assertFalse(os.path.exists(os.path.join(out, "pareto_spheric2_test.csv")))

    def test_missing_column_names_file_and_column(self):
        path = os.path.join(self.fx.peer, "GaugesSWL_H2.csv")
        text = Path(path).read_text().replace("swlz [m]", "level [m]", 1)
        Path(path).write_text(text)
        with self.assertRaises(pc.InputError) as e:
            self.fx.run()
        self.assertIn("GaugesSWL_H2.csv", str(e.exception))
        self.assertIn("'swlz [m]'", str(e.exception))

    def test_bad_value_names_file_column_and_line(self):
        lines = Path(self.fx.steps).read_text().splitlines()
        cells = lines[5].split(",")
        cells[1] = "n/a"
        lines[5] = ",".join(cells)
        Path(self.fx.steps).write_text("\n".join(lines) + "\n")
        with self.assertRaises(pc.InputError) as e:
            self.fx.run()
        self.assertIn("spheric_test2_steps_0.0100.csv", str(e.exception))
        self.assertIn("'P1_pa'", str(e.exception))
        self.assertIn("line 6", str(e.exception))

    def test_short_row_and_command_line_error(self):
        with open(os.path.join(self.fx.peer, "GaugesSWL_H4.csv"), "a") as f:
            f.write("0.802;0.5;0.5\n")
        proc = subprocess.run(
            [sys.executable, str(_BENCH / "peer_compare.py"), "--case", "spheric2", "--repo",
             self.fx.repo, "--out", os.path.join(self.fx.root, "o"), "--run", "0.01",
             self.fx.peer, self.fx.steps], capture_output=True, text=True)
        self.assertEqual(proc.returncode, 2)
        self.assertIn("GaugesSWL_H4.csv", proc.stderr)
        self.assertIn("line 804", proc.stderr)
        self.assertIn("no value from column 'swlz [m]' on", proc.stderr)


class MartinMoyceTest(unittest.TestCase):
    def test_fronts(self):
        with tempfile.TemporaryDirectory() as root:
            fx = Fixture(root)  # for the reference table: (0, 1), (1, 2), (2, 3)
            dp = A / 15
            unit = math.sqrt(A / (2 * G))  # s per unit of T
            peer = os.path.join(root, "mm_peer")
            os.makedirs(os.path.join(peer, "data"))
            write_run_out(peer, dp, 1.41421 * dp, time_part=0.002, two_d=True)
            # The peer's front Z = 1 + 1.2 T (too fast), its column's back row at x = 0.
            for k in range(61):
                T = 0.002 * k / unit
                front = (1 + 1.2 * T) * A - dp
                with open(os.path.join(peer, "data", f"PartCsv_{k:04d}.csv"), "w") as f:
                    f.write("Pos.x [m];Pos.y [m];Pos.z [m];Idp;Vel.x [m/s];Vel.y [m/s];"
                            "Vel.z [m/s];Rho [kg/m^3];Type;\n")
                    f.write("5.0;0;0;0;0;0;0;1000;0;\n")  # a wall particle far right: ignored
                    for x in (0.0, 0.5 * front, front):
                        f.write(f"{x!r};0;0.01;1;0;0;0;1000;3;\n")
            # The project's front Z = (front_x + d / 2) / a = 1 + 0.9 T (too slow).
            probes = os.path.join(root, "probes.csv")
            with open(probes, "w") as f:
                f.write("time,step,front_x,kinetic_energy\n")
                for k in range(61):
                    T = 0.002 * k / unit
                    f.write(f"{0.002 * k!r},{k},{(1 + 0.9 * T) * A - 0.5 * dp!r},0\n")
            rows = pc.main(["--case", "martinmoyce", "--tag", "test", "--repo", fx.repo,
                            "--out", os.path.join(root, "out"), "--run", repr(dp), peer, probes])
            peer_row, project_row = rows
            self.assertEqual(peer_row["code"], "dualsphysics")
            self.assertAlmostEqual(peer_row["front_rms"],
                                   math.sqrt((0.1 ** 2 + (0.4 / 3) ** 2) / 2), places=9)
            self.assertAlmostEqual(peer_row["front_max"], 0.4 / 3, places=9)
            self.assertEqual(peer_row["rows"], 2)
            # Best delay: the minimum of (0.1 - 0.6 s)^2 + (0.4/3 - 0.4 s)^2 lies at
            # s = 0.2179..., on the 0.001 grid s = 0.218.
            self.assertAlmostEqual(peer_row["best_delay_ms"], 0.218 * unit * 1000, places=6)
            e1 = abs(1 + 1.2 * (1 - 0.218) - 2) / 2
            e2 = abs(1 + 1.2 * (2 - 0.218) - 3) / 3
            self.assertAlmostEqual(peer_row["front_rms_best_delay"],
                                   math.sqrt((e1 ** 2 + e2 ** 2) / 2), places=9)
            self.assertAlmostEqual(project_row["front_rms"],
                                   math.sqrt((0.05 ** 2 + (0.2 / 3) ** 2) / 2), places=9)
            self.assertAlmostEqual(project_row["best_delay_ms"], 0.0)
            # Against the converged front (the finest DualSPHysics run, here the only one): the
            # peer against itself is exact; the project's Z = 1 + 0.9 T against 1 + 1.2 T at the
            # peer's samples, and it reaches each level Z later by (Z - 1) (1/0.9 - 1/1.2).
            self.assertEqual(peer_row["converged_dp_m"], repr(dp))
            self.assertEqual(peer_row["front_rms_vs_converged"], 0.0)
            self.assertAlmostEqual(peer_row["lead_vs_converged_ms"], 0.0, places=9)
            Ts = [0.002 * k / unit for k in range(1, 61)]
            expected = math.sqrt(sum((0.3 * T / (1 + 1.2 * T)) ** 2 for T in Ts) / len(Ts))
            self.assertAlmostEqual(project_row["front_rms_vs_converged"], expected, places=9)
            top = 1 + 0.9 * Ts[-1]
            mean_excess = (1.1 + top) / 2 - 1  # the mean of Z - 1 over evenly spaced levels
            lead = mean_excess * (1 / 1.2 - 1 / 0.9) * unit * 1000
            self.assertAlmostEqual(project_row["lead_vs_converged_ms"], lead, places=6)
            self.assertLess(project_row["lead_vs_converged_ms"], 0)
            # No PartCsv files: a clear error naming the directory.
            for name in os.listdir(os.path.join(peer, "data")):
                os.remove(os.path.join(peer, "data", name))
            with self.assertRaises(pc.InputError) as e:
                pc.main(["--case", "martinmoyce", "--repo", fx.repo, "--out",
                         os.path.join(root, "out"), "--run", repr(dp), peer, probes])
            self.assertIn("PartCsv", str(e.exception))
            self.assertIn(os.path.join(peer, "data"), str(e.exception))


if __name__ == "__main__":
    unittest.main()
