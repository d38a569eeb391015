#!/usr/bin/env python3
"""Compare a run of inputs/dam_break_lobovsky.toml with Lobovsky et al. (2014), H = 300 mm.

Usage: python3 tools/lobovsky_compare.py [RUNDIR [REFDATA_DIR]]
(RUNDIR defaults to the newest runs/dam_break_lobovsky*/ of the working directory, REFDATA_DIR to
the experiment's series vendored in inputs/reference/). Standard library only.

Prints, for the pressure sensors S1, S3 and S4 (the digitised experimental curves), the
first-impact peak p/(rho g H) and its time t sqrt(g/H), simulated against experiment, and for the
gauges H1-H4 the mean absolute difference of h/H over t sqrt(g/H) in [0, 8] and the arrival time
of the surge (first h/H > 0.02) against the experiment's series (TNL-SPH's choice of curves).
"""
import csv
import glob
import math
import os
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


def main():
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
    exp_p = rows(os.path.join(ref, "dambreak_lobovsky2014_H300_pressure_digitized.csv"))
    print("sensor | simulated peak p/(rho g H) at t sqrt(g/H) | experiment | peak error | time error")
    for s in ["S1", "S3", "S4"]:
        e = [(float(r["tstar"]), float(r["pstar"])) for r in exp_p if r["sensor"] == s]
        sim = [(t, p / (RHO * G * H)) for t, p in series(os.path.join(run, "probes", s + ".csv"), "p")]
        # the first impact: within 1.5 of the experiment's first rise
        rise = next(t for t, p in e if p > 0.1)
        pe, ps = first_peak(e, rise - 0.5, rise + 1.0), first_peak(sim, rise - 0.5, rise + 1.0)
        print(f"{s} | {ps[1]:.3f} at {ps[0]:.3f} | {pe[1]:.3f} at {pe[0]:.3f} | "
              f"{100 * (ps[1] / pe[1] - 1):+.1f} % | {ps[0] - pe[0]:+.3f}")
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
