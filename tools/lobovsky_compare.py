#!/usr/bin/env python3
"""Compare a run of inputs/dam_break_lobovsky.toml with Lobovsky et al. (2014), H = 300 mm.

Usage: python3 tools/lobovsky_compare.py [RUNDIR [REFDATA_DIR]] [--hsph PATH]
(RUNDIR defaults to the newest runs/dam_break_lobovsky*/ of the working directory, REFDATA_DIR to
the experiment's series vendored in inputs/reference/, PATH to target/release/hsph).
Standard library only.

Prints, for the pressure sensors S1, S3 and S4, the loads docs/pressure.md §1 defines, of the
run's probe series and of the experiment's 20 kHz run through the same code (`hsph loads`): the
maximum after the 2 ms centred box and its time t sqrt(g/H), the raw maximum, and the first
impact's impulse over 35 ms (S1 and S3). S1 and S3 are read over t sqrt(g/H) in [0, 4.5], S4 over
[2, 4.5] (its hump, not a spike before it). Then, for the gauges H1-H4, the mean absolute
difference of h/H over t sqrt(g/H) in [0, 8] and the arrival time of the surge (first
h/H > 0.02) against the experiment's series (TNL-SPH's choice of curves).
"""
import csv
import glob
import json
import math
import os
import subprocess
import sys

H, G, RHO = 0.3, 9.81, 1000.0
TS = math.sqrt(G / H)


def rows(path):
    with open(path) as f:
        return [r for r in csv.DictReader(line for line in f if not line.startswith("#"))]


def series(path, col):
    return [(float(r["t"]) * TS, float(r[col])) for r in rows(path)]


def first_peak(pts, t0, t1):
    window = [p for p in pts if t0 <= p[0] <= t1]
    return max(window, key=lambda p: p[1]) if window else (float("nan"), float("nan"))


def interp(pts, t):
    for (ta, a), (tb, b) in zip(pts, pts[1:]):
        if ta <= t <= tb:
            return a + (b - a) * (t - ta) / max(tb - ta, 1e-300)
    return float("nan")


SPAN = 0.035                  # the impulse's span (s): 0.2 in t sqrt(g/H)
# sensor: (experiment's column, t sqrt(g/H) range read, impulse scored)
SENSORS = {"S1": ("p_sensor1_3mm", (0.0, 4.5), True),
           "S3": ("p_sensor3_30mm", (0.0, 4.5), True),
           "S4": ("p_sensor4_80mm", (2.0, 4.5), False)}


def loads(hsph, path, time, column, time_scale, scale, lo, hi):
    """The loads of one series through `hsph loads` (the code summary.json uses)."""
    cmd = [hsph, "loads", path, "--time", time, "--column", column, "--impulse-span", repr(SPAN),
           "--time-scale", repr(time_scale), "--scale", repr(scale),
           "--from", repr(lo / TS), "--to", repr(hi / TS)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(r.stderr.strip())
    return json.loads(r.stdout)


def main():
    args = sys.argv[1:]
    hsph = "target/release/hsph"
    if "--hsph" in args:
        k = args.index("--hsph")
        hsph = args[k + 1]
        del args[k:k + 2]
    sys.argv = [sys.argv[0]] + args
    if len(sys.argv) > 1:
        run = sys.argv[1]
    else:
        found = glob.glob(os.path.join("runs", "dam_break_lobovsky*", "probes"))
        if not found:
            sys.exit("no RUNDIR given and no runs/dam_break_lobovsky*/ here: "
                     "hsph run inputs/dam_break_lobovsky.toml first, or name the run directory")
        run = os.path.dirname(max(found, key=os.path.getmtime))
        print(f"run: {run}")
    ref = sys.argv[2] if len(sys.argv) > 2 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "inputs", "reference")
    exp_run = os.path.join(ref, "dambreak_lobovsky2014_H300_pressure_run.csv")
    ps = RHO * G * H
    print("sensor | filtered peak p/(rho g H) at t sqrt(g/H), simulated | experiment | error | "
          "raw peak simulated / experiment | impulse (Pa s) simulated / experiment | error")
    for s, (col, (lo, hi), scored) in SENSORS.items():
        sim = loads(hsph, os.path.join(run, "probes", s + ".csv"), "t", "p", 1.0, 1.0, lo, hi)
        exp = loads(hsph, exp_run, "tstar", col, 1.0 / TS, ps, lo, hi)
        err = 100 * (sim["filtered_max"] / exp["filtered_max"] - 1)
        imp = ""
        if scored and sim.get("impulse") and exp.get("impulse"):
            imp = (f"{sim['impulse']:.1f} / {exp['impulse']:.1f} | "
                   f"{100 * (sim['impulse'] / exp['impulse'] - 1):+.1f} %")
        print(f"{s} | {sim['filtered_max'] / ps:.3f} at {sim['filtered_max_t'] * TS:.3f} | "
              f"{exp['filtered_max'] / ps:.3f} at {exp['filtered_max_t'] * TS:.3f} | {err:+.1f} % | "
              f"{sim['raw_max'] / ps:.2f} / {exp['raw_max'] / ps:.2f} | {imp or '|'}")
    lv = rows(os.path.join(ref, "dambreak_lobovsky2014_H300_water_level.csv"))
    print("gauge | mean |h/H - exp| over t* in [0, 8] | arrival t* (h/H > 0.02) simulated / experiment")
    for g, col in [("H1", "h_H1_2"), ("H2", "h_H2_3"), ("H3", "h_H3_3"), ("H4", "h_H4_4")]:
        e = [(float(r["tstar"]), float(r[col])) for r in lv if r[col] not in ("", None)]
        sim = [(t, h / H) for t, h in series(os.path.join(run, "probes", g + ".csv"), "eta")]
        diffs = [abs(interp(sim, t) - h) for t, h in e if 0 <= t <= 8 and not math.isnan(interp(sim, t))]
        mean = sum(diffs) / max(len(diffs), 1)
        arr = lambda pts: next((t for t, h in pts if h > 0.02), float("nan"))
        print(f"{g} | {mean:.4f} | {arr(sim):.3f} / {arr(e):.3f}" if g != "H1" else f"{g} | {mean:.4f} | (in the column at t = 0)")


if __name__ == "__main__":
    main()
