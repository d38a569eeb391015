#!/usr/bin/env python3
"""The bits of every shipped scene: `final.csv` after 40 steps in every mode the scene
accepts (interactions gather/pairs x neighbours lists/cells/verlet), on 1 and 3 ranks.

A scene of more than `--above` particles is coarsened (dx scaled up, the domain grown by 4
spacings on each open side) to about `--particles`, so the whole set runs in a few minutes; a mode the scene refuses
(exit 2, e.g. pair mode with solids) is recorded as refused. A row is
`scene,interactions,neighbours,sha256 of final.csv` (or `refused`), one per scene and mode;
the 1- and 3-rank files must be equal, else the row says `ranks-differ`.

  python3 tools/shipped_bits.py --hsph target/release/hsph > bits.csv      record
  python3 tools/shipped_bits.py --hsph OLD/hsph > old.csv; diff old.csv bits.csv   before/after

`tests/shipped_bits.rs` runs the same set and compares it with `tests/data/shipped_bits.csv`.
"""
import argparse
import glob
import hashlib
import os
import re
import subprocess
import sys
import tempfile
import tomllib

STEPS = 40
MODES = [(i, n) for i in ("gather", "pairs") for n in ("lists", "cells", "verlet")]


def particles(hsph, scene):
    out = subprocess.run([hsph, "check", scene], capture_output=True, text=True, check=True).stdout
    return int(re.search(r"estimate\s+(\d+) particles", out).group(1))


def coarsening(hsph, scene, above, budget):
    """The --set that brings `scene`, if it has more than `above` particles, to about
    `budget`: dx scaled up, the domain grown by 4 new spacings on each open side so that
    walls built outside it (their layers grow with dx) still fit."""
    n = particles(hsph, scene)
    if n <= above:
        return []
    s = tomllib.load(open(scene, "rb"))
    d = s["dimension"]
    dx = s["discretisation"]["dx"] * (n / budget) ** (1.0 / d)
    dom = s["domain"]
    periodic = dom.get("periodic", [False] * d)
    lo = [x - (0 if periodic[a] else 4 * dx) for a, x in enumerate(dom["min"])]
    hi = [x + (0 if periodic[a] else 4 * dx) for a, x in enumerate(dom["max"])]
    fmt = lambda v: "[" + ",".join(f"{x:.9g}" for x in v) + "]"
    return [f"discretisation.dx={dx:.6g}", f"domain.min={fmt(lo)}", f"domain.max={fmt(hi)}"]


def run(hsph, scene, sets, mode, ranks, out):
    cmd = [hsph, "run", scene, "--out", out, "--force", "-q", "--ranks", str(ranks), "--threads", "1",
           "--interactions", mode[0], "--neighbours", mode[1],
           "--set", f"time.max_steps={STEPS}", "--set", 'output.format="none"']
    for s in sets:
        cmd += ["--set", s]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode == 2:
        if os.environ.get("HSPH_BITS_VERBOSE"):
            print(f"{scene} {mode}: {r.stderr.strip()}", file=sys.stderr)
        return "refused"
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: exit {r.returncode}\n{r.stderr}")
    return hashlib.sha256(open(os.path.join(out, "final.csv"), "rb").read()).hexdigest()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hsph", default="target/release/hsph")
    ap.add_argument("--above", type=int, default=24000, help="coarsen scenes with more particles")
    ap.add_argument("--particles", type=int, default=6000, help="to about this many")
    ap.add_argument("scenes", nargs="*")
    a = ap.parse_args()
    scenes = a.scenes or sorted(glob.glob("inputs/*.toml"))
    print("scene,interactions,neighbours,final_sha256")
    with tempfile.TemporaryDirectory() as tmp:
        for scene in scenes:
            sets = coarsening(a.hsph, scene, a.above, a.particles)
            for mode in MODES:
                h = [run(a.hsph, scene, sets, mode, r, os.path.join(tmp, f"r{r}")) for r in (1, 3)]
                row = h[0] if h[0] == h[1] else "ranks-differ"
                print(f"{os.path.basename(scene)},{mode[0]},{mode[1]},{row}", flush=True)


if __name__ == "__main__":
    main()
