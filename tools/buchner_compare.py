#!/usr/bin/env python3
"""Compare a run of inputs/dam_break_buchner.toml with Buchner (2002), H = 0.6 m.

Usage: python3 tools/buchner_compare.py RUNDIR [--hsph PATH] [--reference CSV]
(PATH defaults to target/release/hsph, CSV to the digitised curves vendored in
inputs/reference/dambreak2d_buchner2002_wall_pressure.csv). Standard library only.

For each event it prints the loads of docs/pressure.md §1, through one code (`hsph loads`) on both
sides:
- P1's first impact, t sqrt(g/H) in [2.3, 3.5], for both numerical sensors (P1 at the experiment's
  160 mm, P1_low at 120 mm) against each digitisation of P1 (pysph, jax-sph, trixi);
- P2's peak, t sqrt(g/H) in [4.5, 6.5], against the one digitisation of P2 (trixi).
The run's series goes through the 2 ms centred box; the experiment's curves are digitised from a
figure, so no filter applies to them (`--filter 0`). The impulse is taken over 0.2 in t sqrt(g/H)
(49.5 ms) from the first time the pressure stays above 10 % of its peak for 1 ms, a span fixed
before the first run. A digitised curve is sorted by time and points at an equal time dropped,
since `hsph loads` reads a series whose time increases.
"""
import csv
import json
import math
import os
import subprocess
import sys
import tempfile

H, G, RHO = 0.6, 9.81, 1000.0
TS = math.sqrt(H / G)          # seconds per unit of t sqrt(g/H)
PS = RHO * G * H               # pascals per unit of p/(rho g H)
SPAN = 0.2 * TS                # the impulse's span (s)
REFERENCE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "inputs", "reference",
                         "dambreak2d_buchner2002_wall_pressure.csv")
# event: (experiment's sensor, the run's probes, t sqrt(g/H) range)
EVENTS = [("P1", ["P1", "P1_low"], (2.3, 3.5)), ("P2", ["P2"], (4.5, 6.5))]


def loads(hsph, path, column, lo, hi, filt=None):
    """The loads of one series (t in s, p in Pa) through `hsph loads`."""
    cmd = [hsph, "loads", path, "--column", column, "--impulse-span", repr(SPAN),
           "--from", repr(lo * TS), "--to", repr(hi * TS)]
    if filt is not None:
        cmd += ["--filter", repr(filt)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(r.stderr.strip())
    return json.loads(r.stdout)


def digitised(path):
    """{(source, sensor): [(t s, p Pa)]} of the vendored curves, sorted, equal times dropped."""
    out = {}
    with open(path) as f:
        for r in csv.DictReader(line for line in f if not line.startswith("#")):
            out.setdefault((r["source"], r["sensor"]), []).append(
                (float(r["tstar"]) * TS, float(r["pstar"]) * PS))
    for k, pts in out.items():
        pts.sort()
        out[k] = [p for n, p in enumerate(pts) if n == 0 or p[0] > pts[n - 1][0]]
    return out


def main():
    args = sys.argv[1:]
    opts = {"--hsph": "target/release/hsph", "--reference": REFERENCE}
    for key in list(opts):
        if key in args:
            k = args.index(key)
            opts[key] = args[k + 1]
            del args[k:k + 2]
    if len(args) != 1:
        sys.exit(__doc__)
    run = args[0]
    curves = digitised(opts["--reference"])
    print("event | probe | source | peak p/(rho g H) at t sqrt(g/H), simulated (2 ms box) | experiment "
          "| error | impulse (Pa s) simulated / experiment | error")
    print("|---|---|---|---|---|---:|---|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        for sensor, probes, (lo, hi) in EVENTS:
            for probe in probes:
                sim = loads(opts["--hsph"], os.path.join(run, "probes", probe + ".csv"), "p", lo, hi)
                for (source, s), pts in sorted(curves.items()):
                    if s != sensor:
                        continue
                    path = os.path.join(tmp, f"{source}_{s}.csv")
                    with open(path, "w") as f:
                        f.write("t,p\n" + "".join(f"{t!r},{p!r}\n" for t, p in pts))
                    exp = loads(opts["--hsph"], path, "p", lo, hi, filt=0.0)
                    err = 100 * (sim["filtered_max"] / exp["filtered_max"] - 1)
                    si, ei = sim.get("impulse"), exp.get("impulse")
                    imp = f"{si:.1f} / {ei:.1f} | {100 * (si / ei - 1):+.1f} %" if si and ei else "— | —"
                    print(f"| {sensor} | {probe} | {source} | {sim['filtered_max'] / PS:.3f} at "
                          f"{sim['filtered_max_t'] / TS:.3f} | {exp['filtered_max'] / PS:.3f} at "
                          f"{exp['filtered_max_t'] / TS:.3f} | {err:+.1f} % | {imp} |")


if __name__ == "__main__":
    main()
