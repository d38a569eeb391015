#!/usr/bin/env python3
"""hsph check's memory estimate against the measured peak, scene by scene (issue 85).

For each scene: `hsph check SCENE --ranks R` gives the estimate of the process (the `estimate`
line's "need about ..."); `hsph run SCENE --ranks R --threads 1` to t = STEPS x dt0 (dt0 from
check) gives the measured peak resident set (`summary.json`'s `peak_rss_bytes`). The run is
short: the particle table, the lists and the scratch are all built by the first steps, but an
adaptive region's growth later in the run is not seen.

  python3 tools/memory_estimate.py                       every scene in inputs/, 1 rank
  python3 tools/memory_estimate.py --ranks 3 inputs/dam_break_3d.toml

Standard library only; needs a built hsph (--hsph, default target/release/hsph).
"""
import argparse
import glob
import json
import os
import re
import subprocess
import sys
import tempfile

UNITS = {"B": 1, "kB": 1e3, "MB": 1e6, "GB": 1e9, "TB": 1e12}


def size(text):
    x, u = text.split()
    return float(x) * UNITS[u]


def has_reference_times(scene):
    """True if the scene's [reference] table lists `times` (some reference kinds compare at
    given times, which a short run does not reach)."""
    text = open(scene).read()
    if "\n[reference]" not in text:
        return False
    table = text.split("\n[reference]", 1)[1].split("\n[", 1)[0]
    return re.search(r"^\s*times\s*=", table, re.M) is not None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hsph", default="target/release/hsph")
    ap.add_argument("--ranks", type=int, default=1)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("scenes", nargs="*")
    a = ap.parse_args()
    scenes = a.scenes or sorted(glob.glob("inputs/*.toml"))
    print("| scene | particles | estimate | measured peak | estimate / measured |")
    print("|---|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        for s in scenes:
            c = subprocess.run([a.hsph, "check", s, "--ranks", str(a.ranks)], capture_output=True, text=True)
            est = re.search(r"need about ([0-9.]+ [kMGT]?B)", c.stdout)
            dt = re.search(r"dt₀ ([0-9.e+-]+) s", c.stdout)
            if c.returncode != 0 or not est or not dt:
                print(f"| {s} | check failed: {(c.stderr.strip().splitlines() or ['?'])[-1]} ||||")
                continue
            out = os.path.join(tmp, os.path.basename(s))
            t_end = a.steps * float(dt.group(1))
            r = subprocess.run([a.hsph, "run", s, "--ranks", str(a.ranks), "--threads", "1", "-q", "--force",
                                "--out", out, "--set", f"time.t_end={t_end!r}", "--set", 'output.format="none"']
                               + (["--set", "reference.times=[]"] if has_reference_times(s) else []),
                               capture_output=True, text=True)
            if r.returncode != 0:
                print(f"| {s} | run failed: {(r.stderr.strip().splitlines() or ['?'])[-1]} ||||")
                continue
            summ = json.load(open(os.path.join(out, "summary.json")))
            peak = summ["peak_rss_bytes"]
            e = size(est.group(1))
            print(f"| {os.path.basename(s)} | {summ['particles']} | {e / 1e6:.1f} MB | {peak / 1e6:.1f} MB | "
                  f"{e / peak:.2f} |", flush=True)


if __name__ == "__main__":
    main()
