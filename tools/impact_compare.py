#!/usr/bin/env python3
"""Compare runs of the oblique impact (inputs/impact_oblique_45*.toml) with a reference run.

Usage: python3 tools/impact_compare.py REFERENCE_RUN RUN [RUN ...]
Standard library only. Each argument is a run directory (`hsph run --out DIR`), finished or
still running (a running one is read as far as its files go and marked so).

For each run it prints the hole's major and minor axes (summary.json's hole once the run has
finished, else the last row of probes/hole.csv; m), the energy balance over the run from timeseries.csv,
(E_total(t) + E_removed(t)) / E_total(0) - 1 (J/J), and from summary.json, when the run has
finished, the particle-steps (particles at the start x steps) and the wall time. Every run
after the first is compared with the first: the axes' differences in per cent and the ratio of
particle-steps and of wall time. The targets of issue 35 (a refined run against the uniform
fine one) are checked: hole within 3 % on both axes, at most 0.4 x the particle-steps, energy
balance within 1 %.

Example (docs/refinement.md §4):
    hsph run inputs/impact_oblique_45.toml --set discretisation.dx=1.2e-4 --out u012
    hsph run inputs/impact_oblique_45_refined.toml --out r012
    python3 tools/impact_compare.py u012 r012
"""
import csv
import json
import os
import sys

HOLE_TOL = 0.03
STEPS_MAX = 0.4
ENERGY_TOL = 0.01


def die(msg):
    print(f"impact_compare: {msg}", file=sys.stderr)
    sys.exit(2)


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def read_run(run):
    """What a run directory says about the impact, as far as its files go."""
    out = {"run": run}
    if not os.path.isfile(os.path.join(run, "timeseries.csv")):
        die(f"{run}: no timeseries.csv here; give run directories (hsph run --out DIR)")
    ts = rows(os.path.join(run, "timeseries.csv"))
    if not ts:
        die(f"{run}/timeseries.csv has no rows: is {run} a run directory?")
    e0 = float(ts[0]["total_energy"])
    last = ts[-1]
    out["t"] = float(last["t"])
    out["energy"] = (float(last["total_energy"]) + float(last["removed_energy"])) / e0 - 1.0
    hole = rows(os.path.join(run, "probes", "hole.csv"))
    if not hole:
        die(f"{run}/probes/hole.csv has no rows: the scene needs a hole probe")
    out["major"] = float(hole[-1]["major"])
    out["minor"] = float(hole[-1]["minor"])
    summary = os.path.join(run, "summary.json")
    s = None
    if os.path.exists(summary):
        with open(summary) as f:
            s = json.load(f)
    # a run stopped by a signal or a wall-clock limit writes a summary that says
    # "complete": false; it is continued with `hsph run --restart`
    out["finished"] = s is not None and s.get("complete", True)
    if out["finished"]:
        # `particles_start` in runs whose population changes, else `particles`
        out["particle_steps"] = s.get("particles_start", s["particles"]) * s["steps"]
        if "hole" in s:
            out["major"], out["minor"] = s["hole"]["major_m"], s["hole"]["minor_m"]
            out["settled"] = s["hole"].get("settled")
        out["wall_s"] = s.get("wall_s_all_segments", s.get("wall_s"))
        out["t_end"] = s["t_end"]
    return out


def pct(a, b):
    return 100.0 * (a / b - 1.0) if b else float("nan")


def main(argv):
    if len(argv) < 3:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    runs = [read_run(r) for r in argv[1:]]
    ref = runs[0]
    print(f"{'run':<34} {'t (s)':>10} {'major x minor (mm)':>20} {'energy':>8} "
          f"{'particle-steps':>15} {'wall (s)':>9}")
    for r in runs:
        state = "" if r["finished"] else " (running)"
        ps = f"{r['particle_steps']:.3e}" if r["finished"] else "-"
        wall = f"{r['wall_s']:.0f}" if r["finished"] else "-"
        axes = f"{1e3 * r['major']:.2f} x {1e3 * r['minor']:.2f}"
        print(f"{os.path.basename(os.path.normpath(r['run'])) + state:<34} {r['t']:>10.3e} "
              f"{axes:>20} {100 * r['energy']:>+7.2f}% {ps:>15} {wall:>9}")
    failed = False
    for r in runs[1:]:
        name = os.path.basename(os.path.normpath(r["run"]))
        if ref["major"] == 0.0 or r["major"] == 0.0:
            print(f"\n{name}: no hole yet in one of the runs (t = {r['t']:.3e}, {ref['t']:.3e} s)")
            failed = True
            continue
        dmaj, dmin = pct(r["major"], ref["major"]), pct(r["minor"], ref["minor"])
        hole_ok = abs(dmaj) <= 100 * HOLE_TOL and abs(dmin) <= 100 * HOLE_TOL
        energy_ok = abs(r["energy"]) <= ENERGY_TOL
        print(f"\n{name} against {os.path.basename(os.path.normpath(ref['run']))}:")
        print(f"  hole: major {dmaj:+.1f} %, minor {dmin:+.1f} % "
              f"(target within {100 * HOLE_TOL:.0f} %): {'met' if hole_ok else 'NOT met'}")
        print(f"  energy balance {100 * r['energy']:+.2f} % "
              f"(target within {100 * ENERGY_TOL:.0f} %): {'met' if energy_ok else 'NOT met'}")
        if r["finished"] and ref["finished"]:
            ratio = r["particle_steps"] / ref["particle_steps"]
            steps_ok = ratio <= STEPS_MAX
            print(f"  particle-steps {ratio:.3f} x (target at most {STEPS_MAX} x): "
                  f"{'met' if steps_ok else 'NOT met'}; wall time {r['wall_s'] / ref['wall_s']:.2f} x")
            failed |= not steps_ok
        else:
            print("  particle-steps and wall time: not yet (a run is still going)")
        if abs(r["t"] - ref["t"]) > 1e-3 * max(r["t"], ref["t"]):
            print(f"  note: the runs stop at different times ({r['t']:.3e} and {ref['t']:.3e} s);"
                  " the hole is compared at each run's last probe row")
        failed |= not (hole_ok and energy_ok)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
