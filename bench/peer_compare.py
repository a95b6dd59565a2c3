#!/usr/bin/python3
"""DualSPHysics 5.4 against the project on the same case: the same measures from both.

  bench/peer_compare.py --case spheric2 --tag TAG --out DIR [--tmax S] [--repo ROOT]
                        --run DP PEER_DIR PROJECT_STEPS [--run ...]
                        [--project-run LABEL DP PROJECT_STEPS ...]
  bench/peer_compare.py --case martinmoyce --tag TAG --out DIR [--repo ROOT]
                        --run DP PEER_DIR PROJECT_PROBES [--run ...]

PEER_DIR is a DualSPHysics output directory (Run.out and the gauge CSVs, semicolon separated;
../shared/peers/dualsphysics/README.md). bench/peer_dualsphysics.sh runs both codes and calls
this; see bench/README.md, "Against DualSPHysics".

spheric2 (SPHERIC Test 2; definitions of ../shared/notes/spheric2.md, section 5):
  PROJECT_STEPS is accuracy_bench's spheric_test2_steps_DP.csv (every step's raw P1-P8, H1-H4).
  --project-run adds another project run at DP (another solver or setting, e.g. dfsph) as the
  code project_LABEL, measured the same way; its wall time, for the Pareto plot, is the row of
  that DP in the accuracy_spheric_test2.csv beside its PROJECT_STEPS (accuracy_bench writes both).
  The peer's heights are its `swl` gauges (the dry reading, point0, counts as 0); its pressures
  are the `mesh` gauges' Shepard-corrected density at the point 1.5 h in front of the DBC
  boundary particles (the particle layer snapped to the lattice, as GenCase does), converted by
  the equation of state p = B ((rho / rho0)^7 - 1) with B and rho0 from Run.out.
  Both codes' pressures are time-weighted centred moving averages over 1 ms and 5 ms.
  arrival: the first crossing of 500 Pa by the 1 ms average (spheric2.md's P1 definition; the
    same threshold is used for P2, for which the note defines none), linear between samples.
  peaks: the largest 1 ms and 5 ms averages with 0.40 s <= t <= 0.46 s.
  box force: the largest 1 ms average of -F_x (the flow's push on the box) in the same window,
    from the peer's force gauge GaugesForce_ForceBox.csv and the project's
    spheric_test2_force_DP.csv beside its PROJECT_STEPS (accuracy_bench --step-series), where
    they exist.
  H errors: the RMS of H - H_MARIN at the MARIN rows (every 10 ms) with t <= 0.75 s and with
    t <= tmax (early_end_s and tmax_s: the last rows reached), divided by the water's initial
    depth 0.55 m (H1-H3 start dry, where an error relative to the measured value has no
    meaning; the project's SphericTest2Result does the same).
martinmoyce (Martin & Moyce 1952, 2D column a = 0.05715 m):
  PROJECT_PROBES is `dysa run`'s probes.csv (column front_x); the peer's front is the largest x
  of its fluid particles in data/PartCsv_NNNN.csv (time NNNN * TimePart of Run.out). Both fronts
  are taken at the particles' outer surface, Z = (x_front - x_back + d) / a with x_back the
  column's back row of particle centres at t = 0 (the project's column starts at the wall,
  x_back = d / 2). The error is the RMS of |Z - Z_ref| / Z_ref over the table's rows with T > 0
  that the run reaches, T = t sqrt(2 g / a), with no delay and with the best constant delay.
  Against the converged SPH front (the issue's reference: DualSPHysics's finest run, a/120): the
  RMS of |Z - Z_conv| / Z_conv at its samples, and the mean time by which a run reaches each
  level of Z before it (lead_vs_converged_ms; negative: later).
"""

import argparse
import csv
import math
import os
import re
import sys

import numpy as np

THRESHOLD_PA = 500.0  # spheric2.md section 5: "first crossing of 500 Pa by the 1 ms P1"
PEAK_WINDOW = (0.40, 0.46)  # s
SHORT_WINDOW, LONG_WINDOW = 0.001, 0.005  # s, the moving averages
EARLY_END = 0.75  # s, the first H error window
GAUGE_SLACK = 0.002  # s, how far past a series' last sample a MARIN row may lie
DEPTH = 0.55  # m, the water's initial depth
PROBE_OFFSET_H = 1.5  # the peer's pressure point: 1.5 h from the boundary particles
# MARIN's pressure record as quoted by ../shared/notes/spheric2.md section 0 (from the SPHERIC
# Test 2 data, via vamseeachanta/digitalmodel and chaos-polymtl/lethe): P1 516 Pa at 0.3930 s and
# peak 11.24 kPa at 0.4150 s; P2 onset 0.410 s, peak 8.13 kPa at 0.426 s. No series is stored.
MARIN_PRESSURE = {"P1_arrival_s": 0.393, "P1_peak_pa": 11240.0, "P1_peak_time_s": 0.415,
                  "P2_arrival_s": 0.410, "P2_peak_pa": 8130.0, "P2_peak_time_s": 0.426}
# SPHERIC Test 2's face sensors P1-P4 (x of the face, z heights in the peer's axes) and top
# sensors P5-P8 (x positions, the top at z = 0.161).
FACE_X, TOP_Z = 0.8245, 0.161
TOP_X = (0.8035, 0.7635, 0.7235, 0.6835)  # P5..P8
MM_A, G = 0.05715, 9.81


class InputError(Exception):
    """Malformed or missing input: the message names the file and the column."""


# ---------------------------------------------------------------------------------------------
# Readers


def _number(path, column, text, line):
    try:
        return float(text)
    except ValueError:
        raise InputError(f"{path}: column '{column}', line {line}: '{text.strip()}' is not a "
                         "number") from None


def read_table(path, sep, header_line=0, required=(), max_rows=None):
    """Columns of a delimited file by header name: {name: np.array of float}, the `required`
    columns only (all when none are named). Lines starting with '#' and the lines before
    header_line are skipped; a trailing separator is ignored; max_rows limits the rows read."""
    try:
        with open(path, newline="") as f:
            lines = f.read().splitlines()
    except OSError as e:
        raise InputError(f"{path}: cannot read ({e.strerror})") from None
    body = [(n + 1, l) for n, l in enumerate(lines) if l.strip() and not l.startswith("#")]
    if len(body) <= header_line:
        raise InputError(f"{path}: no header line")
    header = [c.strip() for c in body[header_line][1].rstrip(sep).split(sep)]
    for name in required:
        if name not in header:
            raise InputError(f"{path}: no column '{name}' (columns: {', '.join(header)})")
    rows = body[header_line + 1:]
    if max_rows is not None:
        rows = rows[:max_rows]
    wanted = list(required) if required else header
    if not rows:
        raise InputError(f"{path}: column '{wanted[0]}' has no values")
    index = {name: header.index(name) for name in wanted}
    data = {name: np.empty(len(rows)) for name in wanted}
    for i, (n, line) in enumerate(rows):
        cells = line.rstrip(sep).split(sep)
        if len(cells) != len(header):
            where = (f"no value from column '{header[len(cells)]}' on" if len(cells) < len(header)
                     else f"values after column '{header[-1]}'")
            raise InputError(f"{path}: line {n} has {len(cells)} values for the header's "
                             f"{len(header)} ({where})")
        for name, k in index.items():
            data[name][i] = _number(path, name, cells[k], n)
    return data


def read_run_out(path):
    """The key=value lines of DualSPHysics's Run.out that the conversions need."""
    want = {"KernelH": None, "CteB": None, "RhopZero": None, "Dp": None, "TimePart": None}
    try:
        with open(path) as f:
            for line in f:
                m = re.match(r"^(\w+)=([-+0-9.eE]+)", line.strip())
                if m and m.group(1) in want and want[m.group(1)] is None:
                    want[m.group(1)] = float(m.group(2))
    except OSError as e:
        raise InputError(f"{path}: cannot read ({e.strerror})") from None
    return want


def _need(run, key, path):
    if run.get(key) is None:
        raise InputError(f"{path}: no '{key}=' line")
    return run[key]


def read_peer_heights(directory):
    """H1-H4 from GaugesSWL_Hn.csv: {"Hn": (times, heights)}; the dry reading (point0) is 0."""
    out = {}
    for g in range(1, 5):
        path = os.path.join(directory, f"GaugesSWL_H{g}.csv")
        t = read_table(path, ";", required=("time [s]", "swlz [m]", "pos0z [m]"))
        h = np.where(t["swlz [m]"] > t["pos0z [m]"] + 1e-9, t["swlz [m]"], 0.0)
        out[f"H{g}"] = (t["time [s]"], h)
    return out


def read_peer_mesh(path, run_out_path, run, along, wall, wall_index):
    """A `mesh` gauge's density rows converted to pressure. The gauge is a grid (Npt1 x Npt2
    points from PtRef along Vec1 and Vec2); `along` (1 or 2) is the axis that steps away from the
    wall whose first particle layer lies at the lattice position nearest `wall`; `wall_index`
    picks the point on the other axis. Returns (times, pressure, offset of the chosen point from
    the particle layer in m, whether the 1.5 h point lay outside the gauge)."""
    meta = read_table(path, ";", max_rows=1, required=("Npt1", "Npt2", "PtRef.x [m]", "PtRef.z",
                                                       "Vec1.x [m]", "Vec2.z"))
    n1, n2 = int(meta["Npt1"][0]), int(meta["Npt2"][0])
    h = _need(run, "KernelH", run_out_path)
    dp = _need(run, "Dp", run_out_path)
    b = _need(run, "CteB", run_out_path)
    rho0 = _need(run, "RhopZero", run_out_path)
    start = meta["PtRef.x [m]"][0] if along == 1 else meta["PtRef.z"][0]
    step = meta["Vec1.x [m]"][0] if along == 1 else meta["Vec2.z"][0]
    count = n1 if along == 1 else n2
    layer = round(wall / dp) * dp  # GenCase's roundpos: the particle layer on the lattice
    target = layer + PROBE_OFFSET_H * h
    k = int(round((target - start) / step))
    clamped = k < 0 or k >= count
    k = min(max(k, 0), count - 1)
    i, j = (k, wall_index) if along == 1 else (wall_index, k)
    column = f"v({i}:{j}:0)"
    data = read_table(path, ";", header_line=2, required=("time [s]", column))
    rho = data[column]
    pressure = b * ((rho / rho0) ** 7 - 1.0)
    return data["time [s]"], pressure, start + k * step - layer, clamped


def read_peer_spheric(directory):
    run_out_path = os.path.join(directory, "Run.out")
    run = read_run_out(run_out_path)
    front = os.path.join(directory, "GaugesMesh_PFront_Rhop.csv")
    top = os.path.join(directory, "GaugesMesh_PTop_Rhop.csv")
    series = {}  # name: (times, values), each gauge on its own time base
    notes = []
    for s in range(4):  # P1-P4: along x from the face, height index s
        t, p, offset, clamped = read_peer_mesh(front, run_out_path, run, 1, FACE_X, s)
        series[f"P{s + 1}"] = (t, p)
        if s == 0:
            notes.append(f"mesh PFront at {offset * 1000:.1f} mm from the face's particles" +
                         (f" (1.5h = {PROBE_OFFSET_H * run['KernelH'] * 1000:.1f} mm lies "
                          "outside the gauge: its last point)" if clamped else " (1.5h)"))
    for s in range(4):  # P5-P8: index 0 is P8 (x = 0.6835), so P5 is index 3
        t, p, _, _ = read_peer_mesh(top, run_out_path, run, 2, TOP_Z, 3 - s)
        series[f"P{s + 5}"] = (t, p)
    series.update(read_peer_heights(directory))
    series.update(read_peer_force(directory))
    return series, "; ".join(notes)


def read_peer_force(directory):
    """{"Fx": (times, F_x in N)} from the force gauge's GaugesForce_ForceBox.csv (the fluid's
    force on the box, columns time;force;forcex;forcey;forcez with their units), or {} where the
    run has none."""
    path = os.path.join(directory, "GaugesForce_ForceBox.csv")
    if not os.path.exists(path):
        return {}
    data = read_table(path, ";")
    time = next((c for c in data if c.startswith("time")), None)
    fx = next((c for c in data if c.startswith("forcex")), None)
    if time is None or fx is None:
        raise InputError(f"{path}: no 'time' or 'forcex' column (columns: {', '.join(data)})")
    return {"Fx": (data[time], data[fx])}


def read_project_steps(path):
    """P1-P8 and H1-H4 from accuracy_bench's spheric_test2_steps_DP.csv, and the box force Fx
    from the spheric_test2_force_DP.csv beside it where there is one."""
    names = [f"P{s}_pa" for s in range(1, 9)] + [f"H{g}_m" for g in range(1, 5)]
    data = read_table(path, ",", required=("t_s",) + tuple(names))
    series = {n.split("_")[0]: (data["t_s"], data[n]) for n in names}
    force = os.path.join(os.path.dirname(path),
                         os.path.basename(path).replace("_steps_", "_force_"))
    if force != path and os.path.exists(force):
        f = read_table(force, ",", required=("t_s", "Fx_n"))
        series["Fx"] = (f["t_s"], f["Fx_n"])
    return series


def read_marin_heights(repo):
    path = os.path.join(repo, "server", "validation", "data", "spheric_test2_marin_heights.csv")
    data = read_table(path, ",", required=("t_s", "H1_m", "H2_m", "H3_m", "H4_m"))
    return data["t_s"], [data[f"H{g}_m"] for g in range(1, 5)]


def read_repo_published(repo):
    """kP1ArrivalMeasured and kP1PeakMeasured of validation_impact.h (the project's gate)."""
    path = os.path.join(repo, "server", "validation", "include", "dysa", "validation",
                        "validation_impact.h")
    out = {}
    try:
        text = open(path).read()
    except OSError:
        return out
    for key in ("kP1ArrivalMeasured", "kP1PeakMeasured"):
        m = re.search(key + r"\s*=\s*([0-9.eE+-]+)", text)
        if m:
            out[key] = float(m.group(1))
    return out


# ---------------------------------------------------------------------------------------------
# Measures


def moving_average(times, values, window):
    """Centred moving average over `window` s at each sample, sample k weighted by its step's
    length times[k] - times[k-1] (the first by times[0]); the samples in (t - w/2, t + w/2]. As
    dysa::MovingAverage (validation_impact.h)."""
    t = np.asarray(times, float)
    x = np.asarray(values, float)
    length = np.diff(t, prepend=0.0)
    cw = np.concatenate(([0.0], np.cumsum(length)))
    cx = np.concatenate(([0.0], np.cumsum(length * x)))
    hi = np.searchsorted(t, t + 0.5 * window, side="right")
    lo = np.searchsorted(t, t - 0.5 * window, side="right")
    w = cw[hi] - cw[lo]
    s = cx[hi] - cx[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(w > 0, s / np.where(w > 0, w, 1.0), x)


def first_crossing(times, values, threshold):
    """The first time `values` reaches `threshold`, linear between the samples around it."""
    above = np.nonzero(np.asarray(values) >= threshold)[0]
    if above.size == 0:
        return math.nan
    k = above[0]
    if k == 0:
        return float(times[0])
    t0, t1, v0, v1 = times[k - 1], times[k], values[k - 1], values[k]
    return float(t0 + (threshold - v0) / (v1 - v0) * (t1 - t0))


def peak_in(times, values, lo, hi):
    """The largest value with lo <= t <= hi and its time (no time when it is not above 0: the
    sensor stayed dry)."""
    sel = (times >= lo - 1e-12) & (times <= hi + 1e-12)
    if not sel.any():
        return math.nan, math.nan
    k = np.argmax(np.where(sel, values, -np.inf))
    return float(values[k]), (float(times[k]) if values[k] > 0 else math.nan)


def height_error(times, heights, ref_t, ref_h, end):
    """RMS of H - H_ref over the reference rows with t <= end, / DEPTH, and the last row's time.
    A row up to GAUGE_SLACK after the series' last sample takes that sample (DualSPHysics's last
    gauge reading falls up to one step before its end time)."""
    sel = ((ref_t <= end + 1e-9) & (ref_t <= times[-1] + GAUGE_SLACK + 1e-9) &
           (ref_t >= times[0] - 1e-9))
    if not sel.any():
        return math.nan, math.nan
    sim = np.interp(ref_t[sel], times, heights)
    return float(np.sqrt(np.mean((sim - ref_h[sel]) ** 2)) / DEPTH), float(ref_t[sel][-1])


def spheric_measures(series, ref_t, ref_h, tmax):
    """The measures of one code's series {name: (times, values)}."""
    out = {}
    for p in ("P1", "P2"):
        times = series[p][0]
        short = moving_average(times, series[p][1], SHORT_WINDOW)
        long_ = moving_average(times, series[p][1], LONG_WINDOW)
        out[f"{p}_arrival_s"] = first_crossing(times, short, THRESHOLD_PA)
        out[f"{p}_peak_1ms_pa"], out[f"{p}_peak_1ms_time_s"] = peak_in(times, short, *PEAK_WINDOW)
        out[f"{p}_peak_5ms_pa"], out[f"{p}_peak_5ms_time_s"] = peak_in(times, long_, *PEAK_WINDOW)
    if "Fx" in series:  # the push on the box, towards -x: the peak of -F_x over 1 ms
        times, fx = series["Fx"]
        push = moving_average(times, -fx, SHORT_WINDOW)
        out["Fx_peak_1ms_n"], out["Fx_peak_1ms_time_s"] = peak_in(times, push, *PEAK_WINDOW)
    end = tmax if tmax else max(float(series[f"H{g}"][0][-1]) for g in range(1, 5))
    out["early_end_s"] = out["tmax_s"] = 0.0  # the last MARIN rows the errors reach
    for g in range(4):
        times, h = series[f"H{g + 1}"]
        out[f"H{g + 1}_rms_to_0.75s"], early = height_error(times, h, ref_t, ref_h[g], EARLY_END)
        out[f"H{g + 1}_rms_to_tmax"], last = height_error(times, h, ref_t, ref_h[g], end)
        out["early_end_s"] = max(out["early_end_s"], early)
        out["tmax_s"] = max(out["tmax_s"], last)
    return out


def read_mm_reference(repo):
    path = os.path.join(repo, "server", "validation", "data", "dam_break_martin_moyce_1952_front.csv")
    data = read_table(path, ",", required=("T", "Z"))
    return data["T"], data["Z"]


def read_peer_front(directory):
    """(t, x_front, x_back at t = 0, dp) from DualSPHysics's data/PartCsv_NNNN.csv."""
    run_out_path = os.path.join(directory, "Run.out")
    run = read_run_out(run_out_path)
    every = _need(run, "TimePart", run_out_path)
    dp = _need(run, "Dp", run_out_path)
    data_dir = os.path.join(directory, "data")
    try:
        files = sorted(f for f in os.listdir(data_dir) if re.fullmatch(r"PartCsv_\d+\.csv", f))
    except OSError as e:
        raise InputError(f"{data_dir}: cannot list ({e.strerror}); run DualSPHysics with -sv:csv")
    if not files:
        raise InputError(f"{data_dir}: no PartCsv_NNNN.csv files; run DualSPHysics with -sv:csv")
    times, fronts, back = [], [], None
    for name in files:
        path = os.path.join(data_dir, name)
        d = read_table(path, ";", required=("Pos.x [m]", "Type"))
        # DualSPHysics's particle types: 0 fixed, 1 moving, 2 floating, 3 fluid.
        fluid = d["Type"] == 3
        if not fluid.any():
            raise InputError(f"{path}: column 'Type' has no fluid particles (3)")
        number = int(name[len("PartCsv_"):-len(".csv")])
        times.append(number * every)
        fronts.append(float(d["Pos.x [m]"][fluid].max()))
        if number == 0:
            back = float(d["Pos.x [m]"][fluid].min())
    if back is None:
        raise InputError(f"{data_dir}: no PartCsv_0000.csv (the column at t = 0)")
    return np.array(times), np.array(fronts), back, dp


def front_error(T, Z, ref_T, ref_Z, delay=0.0):
    """RMS and max of |Z(T - delay) - Z_ref(T)| / Z_ref(T) over the rows with T > 0 that the run
    reaches (before T = 0 the column is at rest); and the number of rows."""
    sel = (ref_T > 0) & (ref_T - delay <= T[-1] + 1e-9)
    if not sel.any():
        return math.nan, math.nan, 0
    sim = np.interp(np.maximum(ref_T[sel] - delay, 0.0), T, Z)
    e = np.abs(sim - ref_Z[sel]) / ref_Z[sel]
    return float(np.sqrt(np.mean(e ** 2))), float(e.max()), int(sel.sum())


def mm_measures(t, x_front, x_back, dp, ref_T, ref_Z):
    T = np.asarray(t) * math.sqrt(2 * G / MM_A)
    Z = (np.asarray(x_front) - x_back + dp) / MM_A
    rms, mx, rows = front_error(T, Z, ref_T, ref_Z)
    best = min((front_error(T, Z, ref_T, ref_Z, s / 1000)[0], s / 1000) for s in range(0, 1001))
    return {"front_rms": rms, "front_max": mx, "rows": rows, "best_delay_ms":
            best[1] * math.sqrt(MM_A / (2 * G)) * 1000, "front_rms_best_delay": best[0]}, T, Z


def first_times(levels, T, Z):
    """The first T at which the front Z reaches each level, linear between samples; the front is
    made monotonic by its running maximum (a front read off particles can step back)."""
    z = np.maximum.accumulate(np.asarray(Z, dtype=float))
    z, first = np.unique(z, return_index=True)  # each value's first sample
    return np.interp(levels, z, np.asarray(T, dtype=float)[first])


def against_converged(T, Z, ref_T, ref_Z):
    """The front (T, Z) against the converged SPH front (ref_T, ref_Z), DualSPHysics's finest
    run: the RMS of |Z - Z_ref| / Z_ref at the reference's samples with T > 0 that both reach,
    and the lead in ms: the mean, over 50 levels of Z from 1.1 to the lower of both fronts'
    largest, of the time by which the run reaches each level before the reference."""
    sel = (ref_T > 0) & (ref_T <= T[-1] + 1e-9)
    if not sel.any():
        return math.nan, math.nan
    sim = np.interp(ref_T[sel], T, Z)
    rms = float(np.sqrt(np.mean(((sim - ref_Z[sel]) / ref_Z[sel]) ** 2)))
    top = min(np.max(Z), np.max(ref_Z))
    if top <= 1.1:
        return rms, math.nan
    levels = np.linspace(1.1, top, 50)
    lead = np.mean(first_times(levels, ref_T, ref_Z) - first_times(levels, T, Z))
    return rms, float(lead) * math.sqrt(MM_A / (2 * G)) * 1000


# ---------------------------------------------------------------------------------------------
# Output


def fmt(v):
    if isinstance(v, str):
        return v
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return ""
    return f"{v:.6g}"


def write_series(path, series, tmax):
    """Both codes' gauges as the same measures every ms to tmax: P 1 ms averages, H linear."""
    grid = np.round(np.arange(0.0, tmax + 1e-9, 0.001), 6)
    names = [f"P{s}" for s in range(1, 9)] + [f"H{g}" for g in range(1, 5)]
    cols = [grid]
    for n in names:
        times, v = series[n]
        if n[0] == "P":
            v = moving_average(times, v, SHORT_WINDOW)
        cols.append(np.interp(grid, times, v))
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["t_s"] + [f"{n}_1ms_pa" if n[0] == "P" else f"{n}_m" for n in names])
        for row in zip(*cols):
            w.writerow([f"{v:.6g}" for v in row])


def plot_spheric(path, curves, ref_t, ref_h):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(3, 1, figsize=(9, 10), sharex=True)
    for label, series in curves:
        t, p = series["P1"]
        ax[0].plot(t, moving_average(t, p, SHORT_WINDOW) / 1000, label=label, lw=0.8)
        ax[1].plot(*series["H2"], label=label, lw=0.9)
        ax[2].plot(*series["H4"], label=label, lw=0.9)
    m = MARIN_PRESSURE
    ax[0].plot([m["P1_arrival_s"], m["P1_peak_time_s"]], [0.516, m["P1_peak_pa"] / 1000], "ko",
               label="MARIN P1: 516 Pa, peak")
    ax[0].set_ylabel("P1, 1 ms average (kPa)")
    ax[1].plot(ref_t, ref_h[1], "k.", ms=3, label="MARIN")
    ax[1].set_ylabel("H2 (m)")
    ax[2].plot(ref_t, ref_h[3], "k.", ms=3, label="MARIN")
    ax[2].set_ylabel("H4 (m)")
    ax[2].set_xlabel("t (s)")
    tmax = max(float(c[1]["P1"][0][-1]) for c in curves)
    for a in ax:
        a.set_xlim(0, tmax)
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
    codes = "DualSPHysics 5.4 and the project" if any(
        label.startswith("dualsphysics") for label, _ in curves) else "the project's runs"
    ax[0].set_title(f"SPHERIC Test 2: {codes}, same dp")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot_mm(path, curves, ref_T, ref_Z):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 5))
    for label, T, Z in curves:
        ax.plot(T, Z, label=label)
    ax.plot(ref_T, ref_Z, "ko", label="Martin & Moyce 1952")
    ax.set_xlabel("T = t sqrt(2 g / a)")
    ax.set_ylabel("Z = x / a")
    ax.set_xlim(0, max(ref_T) * 1.05)
    ax.set_ylim(0.9, max(ref_Z) * 1.25)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def read_throughput(path):
    """{(code, dp): wall seconds} of peer_dualsphysics.sh's peer_throughput_CASE_TAG.csv."""
    try:
        with open(path, newline="") as f:
            table = list(csv.DictReader(f))
    except OSError as e:
        raise InputError(f"{path}: cannot read ({e.strerror})") from None
    wall = {}
    for n, r in enumerate(table, start=2):
        for name in ("code", "dp_m", "wall_s"):
            if r.get(name) is None:
                raise InputError(f"{path}: line {n} has no '{name}'")
        wall[(r["code"], _number(path, "dp_m", r["dp_m"], n))] = _number(path, "wall_s",
                                                                          r["wall_s"], n)
    return wall


PARETO_MEASURES = (
    ("P1_peak_1ms_rel_error", "P1 1 ms peak, |error| / 11.24 kPa"),
    ("P1_arrival_error_ms", "P1 arrival, |error| (ms)"),
    ("H4_rms_to_0.75s", "H4 RMS to 0.75 s / 0.55 m"),
)


def read_accuracy_wall(steps_path, dp):
    """The wall time of accuracy_bench's row for dp in the accuracy_spheric_test2.csv beside its
    steps file; None where there is none."""
    path = os.path.join(os.path.dirname(os.path.abspath(steps_path)), "accuracy_spheric_test2.csv")
    if not os.path.exists(path):
        return None
    table = read_table(path, ",", required=("spacing_m", "wall_s"))
    for spacing, wall in zip(table["spacing_m"], table["wall_s"]):
        if abs(spacing - float(dp)) < 1e-9:
            return float(wall)
    return None


def pareto_rows(rows, wall):
    """Wall time against the errors, one row per code and spacing that has both."""
    m = MARIN_PRESSURE
    out = []
    for r in rows:
        if r["code"] != "dualsphysics" and not r["code"].startswith("project"):
            continue
        key = (r["code"], float(r["dp_m"]))
        if key not in wall:
            continue
        peak, arrival = r.get("P1_peak_1ms_pa"), r.get("P1_arrival_s")
        dry = peak is None or not peak > 0  # no reading at the sensor (the peer's wall gap)
        out.append({
            "code": r["code"], "dp_m": float(r["dp_m"]), "wall_s": wall[key],
            "P1_peak_1ms_rel_error": math.nan if dry else abs(peak - m["P1_peak_pa"]) /
            m["P1_peak_pa"],
            "P1_arrival_error_ms": math.nan if dry or arrival is None or math.isnan(arrival)
            else abs(arrival - m["P1_arrival_s"]) * 1000,
            "H4_rms_to_0.75s": r.get("H4_rms_to_0.75s"),
        })
    return out


def write_pareto(args, rows, extra_wall=None):
    """pareto_spheric2_TAG.csv/png: each code's wall time against its errors, where
    peer_throughput_spheric2_TAG.csv (peer_dualsphysics.sh) is in --out; None without it.
    extra_wall: {(code, dp): wall s} of the --project-run runs, beside that file's."""
    path = os.path.join(args.out, f"peer_throughput_spheric2_{args.tag}.csv")
    if not os.path.exists(path):
        print(f"no {path}: no Pareto plot (peer_dualsphysics.sh writes it)")
        return None
    wall = read_throughput(path)
    wall.update(extra_wall or {})
    points = pareto_rows(rows, wall)
    csv_path = os.path.join(args.out, f"pareto_spheric2_{args.tag}.csv")
    keys = ["code", "dp_m", "wall_s"] + [k for k, _ in PARETO_MEASURES]
    with open(csv_path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(keys)
        for r in points:
            w.writerow([fmt(r[k]) for k in keys])
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, len(PARETO_MEASURES), figsize=(13, 4))
    for a, (key, label) in zip(ax, PARETO_MEASURES):
        codes = sorted({r["code"] for r in points}, key=lambda c: (c != "dualsphysics", c))
        for code, marker in zip(codes, "so^vD<>"):
            pts = sorted((r["wall_s"], r[key], r["dp_m"]) for r in points
                         if r["code"] == code and r[key] is not None and not math.isnan(r[key]))
            if not pts:
                continue
            a.plot([p[0] for p in pts], [p[1] for p in pts], marker=marker, label=code)
            for x, y, dp in pts:
                a.annotate(f"{dp:g}", (x, y), fontsize=7, xytext=(3, 3),
                           textcoords="offset points")
        a.set_xscale("log")
        a.set_xlabel("wall time (s)")
        a.set_ylabel(label)
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
    fig.suptitle(f"SPHERIC Test 2 ({args.tag}): wall time against error, labels dp (m); "
                 "a code without a P1 reading has no point there")
    fig.tight_layout()
    png = os.path.join(args.out, f"pareto_spheric2_{args.tag}.png")
    fig.savefig(png, dpi=90)
    plt.close(fig)
    print(f"wrote {csv_path} and {png}")
    return points


def run_spheric(args, repo):
    ref_t, ref_h = read_marin_heights(repo)
    columns = ["code", "dp_m", "pressure_source"]
    keys = ["P1_arrival_s", "P1_arrival_error_s", "P1_peak_1ms_pa", "P1_peak_1ms_time_s",
            "P1_peak_5ms_pa", "P1_peak_5ms_time_s", "P2_arrival_s", "P2_arrival_error_s",
            "P2_peak_1ms_pa", "P2_peak_1ms_time_s", "P2_peak_5ms_pa", "P2_peak_5ms_time_s"]
    keys += [f"H{g}_rms_to_0.75s" for g in range(1, 5)] + ["early_end_s", "tmax_s"]
    keys += [f"H{g}_rms_to_tmax" for g in range(1, 5)]
    keys += ["Fx_peak_1ms_n", "Fx_peak_1ms_time_s"]
    rows, curves = [], []
    m = MARIN_PRESSURE
    rows.append({"code": "experiment", "dp_m": "", "pressure_source":
                 "MARIN record as quoted in shared/notes/spheric2.md (1 kHz; no series stored)",
                 "P1_arrival_s": m["P1_arrival_s"], "P1_peak_1ms_pa": m["P1_peak_pa"],
                 "P1_peak_1ms_time_s": m["P1_peak_time_s"], "P2_arrival_s": m["P2_arrival_s"],
                 "P2_peak_1ms_pa": m["P2_peak_pa"], "P2_peak_1ms_time_s": m["P2_peak_time_s"]})
    pub = read_repo_published(repo)
    if pub:
        rows.append({"code": "experiment_published", "dp_m": "", "pressure_source":
                     "validation_impact.h kP1ArrivalMeasured/kP1PeakMeasured "
                     "(the project's gate)",
                     "P1_arrival_s": pub.get("kP1ArrivalMeasured"),
                     "P1_peak_1ms_pa": pub.get("kP1PeakMeasured")})
    runs = []
    for dp, peer_dir, project_file in args.run:
        ps, note = read_peer_spheric(peer_dir)
        runs.append((dp, "dualsphysics", ps, note))
        runs.append((dp, "project", read_project_steps(project_file),
                     "wall_pressure probes on the box (every step)"))
    extra_wall = {}  # (code, dp): wall s of the --project-run runs
    for label, dp, project_file in args.project_run or []:
        code = f"project_{label}"
        runs.append((dp, code, read_project_steps(project_file),
                     f"wall_pressure probes on the box (every step), {label}"))
        wall = read_accuracy_wall(project_file, dp)
        if wall is not None:
            extra_wall[(code, float(dp))] = wall
    for dp, code, series, source in runs:
        r = spheric_measures(series, ref_t, ref_h, args.tmax)
        for p in ("P1", "P2"):
            r[f"{p}_arrival_error_s"] = r[f"{p}_arrival_s"] - m[f"{p}_arrival_s"]
        r.update({"code": code, "dp_m": dp, "pressure_source": source})
        rows.append(r)
        curves.append((f"{code} dp {dp}", series))
        last = min(float(series[n][0][-1]) for n in series)
        write_series(os.path.join(args.out, f"peer_series_spheric2_{code}_{dp}_{args.tag}.csv"),
                     series, min(args.tmax, last) if args.tmax else last)
        print(f"{code:13s} dp {dp}: P1 arrival {fmt(r['P1_arrival_s'])} s, 1 ms peak "
              f"{fmt(r['P1_peak_1ms_pa'])} Pa, 5 ms peak {fmt(r['P1_peak_5ms_pa'])} Pa; P2 "
              f"arrival {fmt(r['P2_arrival_s'])} s; H2/H4 RMS to 0.75 s "
              f"{fmt(r['H2_rms_to_0.75s'])}/{fmt(r['H4_rms_to_0.75s'])}")
    out_csv = os.path.join(args.out, f"peer_compare_spheric2_{args.tag}.csv")
    with open(out_csv, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(columns + keys)
        for r in rows:
            w.writerow([fmt(r.get(k)) for k in columns + keys])
    png = os.path.join(args.out, f"peer_compare_spheric2_{args.tag}.png")
    plot_spheric(png, curves, ref_t, ref_h)
    print(f"wrote {out_csv} and {png}")
    write_pareto(args, rows, extra_wall)
    return rows


def run_mm(args, repo):
    ref_T, ref_Z = read_mm_reference(repo)
    keys = ["code", "dp_m", "front_rms", "front_max", "rows", "best_delay_ms",
            "front_rms_best_delay", "converged_dp_m", "front_rms_vs_converged",
            "lead_vs_converged_ms"]
    rows, curves = [], []
    for dp, peer_dir, project_file in args.run:
        t, xf, xb, pdp = read_peer_front(peer_dir)
        r, T, Z = mm_measures(t, xf, xb, pdp, ref_T, ref_Z)
        r.update(code="dualsphysics", dp_m=dp)
        rows.append(r)
        curves.append((f"dualsphysics dp {dp}", T, Z))
        d = read_table(project_file, ",", required=("time", "front_x"))
        jdp = float(dp)
        r, T, Z = mm_measures(d["time"], d["front_x"], 0.5 * jdp, jdp, ref_T, ref_Z)
        r.update(code="project", dp_m=dp)
        rows.append(r)
        curves.append((f"project dp {dp}", T, Z))
    # The converged SPH front: DualSPHysics's finest run (the reference at a/120).
    finest = min(range(0, len(curves), 2), key=lambda k: float(rows[k]["dp_m"]))
    _, conv_T, conv_Z = curves[finest]
    for r, (_, T, Z) in zip(rows, curves):
        r["converged_dp_m"] = rows[finest]["dp_m"]
        r["front_rms_vs_converged"], r["lead_vs_converged_ms"] = against_converged(
            T, Z, conv_T, conv_Z)
    out_csv = os.path.join(args.out, f"peer_compare_martinmoyce_{args.tag}.csv")
    with open(out_csv, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(keys)
        for r in rows:
            w.writerow([fmt(r[k]) if k != "rows" else r[k] for k in keys])
            print(f"{r['code']:13s} dp {r['dp_m']}: front RMS {100 * r['front_rms']:.1f}% "
                  f"(best delay {r['best_delay_ms']:.1f} ms: "
                  f"{100 * r['front_rms_best_delay']:.1f}%); against DualSPHysics at dp "
                  f"{r['converged_dp_m']}: {100 * r['front_rms_vs_converged']:.2f}% RMS, lead "
                  f"{fmt(r['lead_vs_converged_ms'])} ms")
    png = os.path.join(args.out, f"peer_compare_martinmoyce_{args.tag}.png")
    plot_mm(png, curves, ref_T, ref_Z)
    print(f"wrote {out_csv} and {png}")
    return rows


def main(argv=None):
    """Parses argv, writes the outputs and returns the comparison's rows; raises InputError for
    malformed input (cli() prints it)."""
    here = os.path.dirname(os.path.abspath(__file__))
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--case", required=True, choices=("spheric2", "martinmoyce"))
    p.add_argument("--run", nargs=3, action="append", default=[],
                   metavar=("DP", "PEER_DIR", "PROJECT_FILE"))
    p.add_argument("--project-run", nargs=3, action="append",
                   metavar=("LABEL", "DP", "PROJECT_STEPS"),
                   help="spheric2: another project run (e.g. a solver) at DP, as project_LABEL")
    p.add_argument("--out", required=True)
    p.add_argument("--tag", default="cpu", help="GPU name or cpu: the output files' suffix")
    p.add_argument("--tmax", type=float, default=None, help="end of the H errors (s)")
    p.add_argument("--repo", default=os.path.dirname(here), help="the repository's root")
    args = p.parse_args(argv)
    if not args.run and not args.project_run:
        p.error("give at least one --run (or, for spheric2, --project-run)")
    if args.project_run and args.case != "spheric2":
        p.error("--project-run is for --case spheric2")
    dps = [("--run", r[0]) for r in args.run] + [("--project-run", r[1])
                                                 for r in args.project_run or []]
    for flag, dp in dps:
        try:
            if float(dp) <= 0:
                raise ValueError
        except ValueError:
            p.error(f"{flag} DP '{dp}' must be a positive number (m)")
    os.makedirs(args.out, exist_ok=True)
    return run_spheric(args, args.repo) if args.case == "spheric2" else run_mm(args, args.repo)


def cli():
    try:
        main()
    except InputError as e:
        print(f"peer_compare.py: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(cli())
