#!/usr/bin/env python3
"""Where the wall-pressure overshoot of the Lobovsky dam break comes from (docs/pressure.md).

Runs inputs/dam_break_lobovsky.toml to t sqrt(g/H) = 4.57 at one resolution in several
variants (the formulation it ships, the Riemann solver's terms, and delta-SPH as before;
sound speed, the corner's wall volume, density diffusion, wall method and slip, CFL),
each with its pressure probes sampled at every step and no trailing window, and reads the
loads `summary.json` gives them (`pressure_loads`: the raw maximum, the maximum after the 2 ms
centred box, the first impact's impulse over 35 ms). The experiment's 20 kHz run goes through
the same code (`hsph loads`). Prints one markdown row per variant and sensor.

  python3 tools/pressure_diagnosis.py --dx 0.01                 every variant at 10 mm
  python3 tools/pressure_diagnosis.py --dx 0.005 base riemann   delta-SPH and the shipped scene at 5 mm

Standard library only; needs a built hsph (--hsph, default target/release/hsph).
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile

H, G, RHO = 0.3, 9.81, 1000.0
TS = math.sqrt(H / G)          # seconds per unit of t sqrt(g/H)
PS = RHO * G * H               # pascals per unit of p/(rho g H)
SPAN = 0.035                   # the impulse's span: 0.2 in t sqrt(g/H)
T_END = 0.8                    # t sqrt(g/H) = 4.57: the first impacts and S4's hump
SENSORS = {"S1": (0, "p_sensor1_3mm"), "S3": (2, "p_sensor3_30mm"), "S4": (3, "p_sensor4_80mm")}
EXPERIMENT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "inputs", "reference",
                          "dambreak_lobovsky2014_H300_pressure_run.csv")

# The shipped scene runs the Riemann solver's terms; the δ-SPH variants start from the
# formulation it shipped with before (Antuono's density diffusion, δ = 0.1, symmetric pressure).
DSPH = ['physics.density_diffusion="antuono"', "physics.delta=0.1", 'physics.pressure_gradient="symmetric"']
VARIANTS = {
    "base": DSPH,
    "c0_50": DSPH + ["material[0].c0=50.0"],
    "c0_100": DSPH + ["material[0].c0=100.0"],
    "lattice_volume": DSPH + ['wall[0].volume="lattice"'],
    "diffusion_none": DSPH + ['physics.density_diffusion="none"'],
    "diffusion_molteni": DSPH + ['physics.density_diffusion="molteni"'],
    "diffusion_fourtakas": DSPH + ['physics.density_diffusion="fourtakas"'],
    "no_slip": DSPH + ['wall[0].slip="no_slip"'],
    "dynamic_wall": DSPH + ['wall[0].method="dynamic"'],
    "cfl_0.1": DSPH + ["time.cfl=0.1"],
    "cfl_0.2": DSPH + ["time.cfl=0.2"],
    "cfl_0.3": DSPH + ["time.cfl=0.3"],
    "delta_0.3": DSPH + ["physics.delta=0.3"],
    "delta_0.5": DSPH + ["physics.delta=0.5"],
    "alpha_0.1": DSPH + ["physics.artificial_viscosity=0.1"],
    "riemann": [],
    "riemann_pressure": DSPH + ['physics.pressure_gradient="riemann"'],
    "riemann_density": ['physics.pressure_gradient="symmetric"'],
    "riemann_lattice": ['wall[0].volume="lattice"'],
    "riemann_no_slip": ['wall[0].slip="no_slip"'],
    "riemann_c0_50": ["material[0].c0=50.0"],
    "riemann_cfl_0.2": ["time.cfl=0.2"],
    "riemann_cfl_0.3": ["time.cfl=0.3"],
    "riemann_shifting": ['physics.shifting="delta_plus"', "discretisation.h_over_dx=2.0"],
    "riemann_shifting_h13": ['physics.shifting="delta_plus"'],
    "riemann_h2": ["discretisation.h_over_dx=2.0"],
    "riemann_h17": ["discretisation.h_over_dx=1.7"],
    "riemann_alpha_0": ["physics.artificial_viscosity=0.0"],
    "riemann_refine_1": ['time.stepping="local"'],
    "riemann_refine_1_t4": ['time.stepping="local"'],
    "riemann_refine_2": ['time.stepping="local"'],
    "riemann_refine_1_cfl_0.2": ['time.stepping="local"', "time.cfl=0.2"],
    "riemann_refine_1_cfl_0.3": ['time.stepping="local"', "time.cfl=0.3"],
    "riemann_refine_1_wide": ['time.stepping="local"'],
    "riemann_refine_2_wide": ['time.stepping="local"'],
    "riemann_refine_1_global": [],
    "riemann_refine_2_global": [],
    "riemann_density_refine_2": ['time.stepping="local"', 'physics.pressure_gradient="symmetric"'],
    "riemann_fine_wall_2": [],
    "riemann_fine_wall_1": [],
    "riemann_fine_wall_2_scene_h": [],
    "riemann_refine_2_wall_scene_h": ['time.stepping="local"'],
    "riemann_refine_2_scene_h": [],
    "riemann_fine_wall_2_max": ['discretisation.pair_h="max"'],
    "riemann_refine_2_max": ['time.stepping="local"', 'discretisation.pair_h="max"'],
    "riemann_refine_2_global_max": ['discretisation.pair_h="max"'],
    "difference_refine_2_global": ['physics.pressure_gradient="difference"'],
    "riemann_refine_2_tall_global": [],
    "riemann_refine_2_global_h2": ["discretisation.h_over_dx=2.0"],
    "riemann_refine_2_global_h2_shifting": ["discretisation.h_over_dx=2.0", 'physics.shifting="delta_plus"'],
    "riemann_refine_2_global_shifting": ['physics.shifting="delta_plus"'],
    "riemann_refine_1_global_shifting": ['physics.shifting="delta_plus"'],
    "riemann_refine_2_shifting": ['time.stepping="local"', 'physics.shifting="delta_plus"'],
    "riemann_blocks": [],
    "riemann_floor_no_slip": [],
    "riemann_floor_no_slip_h17": ["discretisation.h_over_dx=1.7"],
}

# Variants whose tank is three wall blocks (floor under both corners, upstream and downstream
# walls), each three layers thick, instead of the container: name -> the floor's slip. With a
# free-slip floor the particles are the container's; a no-slip floor slows the surge's tip on
# the bed without slowing the run-up on the downstream wall.
BLOCKS = {"riemann_blocks": "free_slip", "riemann_floor_no_slip": "no_slip",
          "riemann_floor_no_slip_h17": "no_slip"}

# Variants that refine the downstream corner (docs/pressure.md §2e): an adaptive region over
# x in [1.46, 1.66] m, y < 0.2 m (S1-S4 and the run-up's root), at `level` (dx / 2^level, the
# level's h), with local time steps; (level, transition in m or None for one support).
# name: (level, transition in m or None, region's upstream x in m, region's top y in m)
CORNER = (1.46, 0.2)
WIDE = (1.06, 0.45)
TALL = (1.46, 0.8)   # the corner region, its top face above the run-up
REGIONS = {"riemann_refine_1": (1, None, *CORNER), "riemann_refine_1_t4": (1, 0.052, *CORNER),
           "riemann_refine_2": (2, None, *CORNER),
           "riemann_refine_1_cfl_0.2": (1, None, *CORNER), "riemann_refine_1_cfl_0.3": (1, None, *CORNER),
           "riemann_refine_1_wide": (1, None, *WIDE),
           "riemann_refine_1_global": (1, None, *CORNER), "riemann_refine_2_wide": (2, None, *WIDE),
           "riemann_refine_2_global": (2, None, *CORNER),
           "riemann_density_refine_2": (2, None, *CORNER),
           "riemann_fine_wall_2": (2, None, *CORNER), "riemann_fine_wall_1": (1, None, *CORNER),
           "riemann_fine_wall_2_scene_h": (2, None, *CORNER),
           "riemann_refine_2_wall_scene_h": (2, None, *CORNER),
           "riemann_refine_2_scene_h": (2, None, *CORNER),
           "riemann_fine_wall_2_max": (2, None, *CORNER), "riemann_refine_2_max": (2, None, *CORNER),
           "riemann_refine_2_global_max": (2, None, *CORNER),
           "difference_refine_2_global": (2, None, *CORNER),
           "riemann_refine_2_tall_global": (2, None, *TALL),
           "riemann_refine_2_global_h2": (2, None, *CORNER),
           "riemann_refine_2_global_h2_shifting": (2, None, *CORNER),
           "riemann_refine_2_global_shifting": (2, None, *CORNER),
           "riemann_refine_1_global_shifting": (1, None, *CORNER),
           "riemann_refine_2_shifting": (2, None, *CORNER)}
# Variants whose fluid region adapts at the level's h while a second, static region refines the
# tank's walls at the same level with the scene's h
SPLIT_WALL = {"riemann_refine_2_wall_scene_h"}
# Variants whose region refines the tank's walls alone, statically (the fluid stays at dx)
WALL_ONLY = {"riemann_fine_wall_2", "riemann_fine_wall_1", "riemann_fine_wall_2_scene_h", "riemann_fine_wall_2_max"}
# Variants whose refined particles keep the scene's h (smoothing_length = "scene")
SCENE_H = {"riemann_fine_wall_2_scene_h", "riemann_refine_2_scene_h"}


THREADS = []  # ["--threads", "N"] with --threads


def scene_with_region(level, transition, x0, y1, tmp, walls_only=False, scene_h=False, split_wall=False):
    """The shipped scene with a refinement region over the downstream corner, x >= x0 and y < y1
    (m), appended and written into `tmp`; adaptive over the column and the tank, or with
    `walls_only` a static refinement of the tank's walls alone."""
    text = open("inputs/dam_break_lobovsky.toml").read()
    bodies = '["tank"]' if walls_only else '["column", "tank"]'
    adapt = "false" if walls_only else "true"
    if split_wall:
        bodies = '["column"]'
        text += (f'\n[[refine]]\nmin = [{x0}, -0.05]\nmax = [1.66, {y1}]\nlevel = {level}\n'
                 'bodies = ["tank"]\nsmoothing_length = "scene"\nadapt = false\n')
    text += (f'\n[[refine]]\nmin = [{x0}, -0.05]\nmax = [1.66, {y1}]\nlevel = {level}\n'
             f'bodies = {bodies}\nsmoothing_length = "{"scene" if scene_h else "level"}"\nadapt = {adapt}\n')
    if transition is not None:
        text += f"transition = {transition}\n"
    path = os.path.join(tmp, f"lobovsky_refine_{level}_{x0}_{y1}_{bodies.count(',')}_{scene_h}_{split_wall}.toml")
    open(path, "w").write(text)
    return path


def scene_with_blocks(floor_slip, dx, tmp):
    """The shipped scene with its container replaced by three blocks of three layers at `dx`
    (m): the floor, of slip `floor_slip`, under both corners; the two end walls free-slip."""
    text = open("inputs/dam_break_lobovsky.toml").read()
    start = text.index("[[wall]]")
    end = text.index("[reference]")
    d = 3 * dx
    blocks = ""
    for name, lo, hi, slip in (("floor", [-d, -d], [1.61 + d, 0.0], floor_slip),
                               ("upstream", [-d, 0.0], [0.0, 0.8], "free_slip"),
                               ("downstream", [1.61, 0.0], [1.61 + d, 0.8], "free_slip")):
        blocks += (f'[[wall]]\nname = "{name}"\nshape = "block"\nmin = [{lo[0]!r}, {lo[1]!r}]\n'
                   f'max = [{hi[0]!r}, {hi[1]!r}]\nmethod = "dummy"\nslip = "{slip}"\n\n')
    path = os.path.join(tmp, f"lobovsky_blocks_{floor_slip}_{dx}.toml")
    open(path, "w").write(text[:start] + blocks + text[end:])
    return path


def with_surge_probes(scene, tmp, name):
    """`scene` with gauges and velocity lines (every 2.5 ms) at x = 1.40, 1.50, 1.58 m, the
    surge's depth and speed before and inside the corner region, written into `tmp`."""
    text = open(scene).read()
    for k, x in enumerate((1.40, 1.50, 1.58)):
        text += (f'\n[[probe]]\nname = "G{k}"\nkind = "gauge"\npoint = [{x}, 0.0]\ninterval = 0.0025\n'
                 f'\n[[probe]]\nname = "U{k}"\nkind = "velocity_line"\nfrom = [{x}, 0.0025]\n'
                 f'to = [{x}, 0.0475]\npoints = 10\ninterval = 0.0025\n')
    path = os.path.join(tmp, f"surge_{name}.toml")
    open(path, "w").write(text)
    return path


def loads_of_experiment(hsph, column, lo, hi):
    out = subprocess.run([hsph, "loads", EXPERIMENT, "--time", "tstar", "--column", column,
                          "--time-scale", repr(TS), "--scale", repr(PS), "--impulse-span", repr(SPAN),
                          "--from", repr(lo * TS), "--to", repr(hi * TS)],
                         capture_output=True, text=True, check=True).stdout
    return json.loads(out)


def run(hsph, dx, sets, out, scene="inputs/dam_break_lobovsky.toml"):
    # a coarser lattice builds the container's layers further out: grow the domain to fit
    cmd = [hsph, "run", scene, "--out", out, "--force", "-q", *THREADS,
           "--set", f"discretisation.dx={dx}", "--set", f"time.t_end={T_END}",
           "--set", "domain.min=[-0.05,-0.05]", "--set", "domain.max=[1.66,0.85]"]
    for name, (k, _) in SENSORS.items():
        cmd += ["--set", f"probe[{k}].window=0.0", "--set", f"probe[{k}].interval=0.0",
                "--set", f"probe[{k}].impulse_span={SPAN}"]
    for s in sets:
        cmd += ["--set", s]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        return None, r.stderr.strip().splitlines()[-1]
    return json.load(open(os.path.join(out, "summary.json"))), None


def overshoot_s(run_dir, name, level):
    """Seconds the raw series spends above `level` (Pa)."""
    rows = [l.split(",") for l in open(os.path.join(run_dir, "probes", name + ".csv")).read().split("\n")[1:] if l]
    pts = [(float(a), float(b)) for a, b in rows]
    return sum(tb - ta for (ta, pa), (tb, _) in zip(pts, pts[1:]) if pa > level)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hsph", default="target/release/hsph")
    ap.add_argument("--dx", type=float, default=0.01)
    ap.add_argument("--keep", metavar="DIR", help="keep each variant's run in DIR/<variant> (default: a temporary "
                    "directory, removed at the end)")
    ap.add_argument("--threads", type=int, help="passed to hsph run")
    ap.add_argument("--surge-probes", action="store_true", help="add gauges and velocity lines where the "
                    "surge enters the corner region (x = 1.40, 1.50, 1.58 m): its depth and speed in "
                    "probes/G*.csv and probes/U*.csv")
    ap.add_argument("variants", nargs="*", help=f"default: all of {', '.join(VARIANTS)}")
    a = ap.parse_args()
    names = a.variants or list(VARIANTS)
    for n in names:
        if n not in VARIANTS:
            sys.exit(f"unknown variant `{n}`; variants: {', '.join(VARIANTS)}")
    exp = {s: loads_of_experiment(a.hsph, col, 2.0 if s == "S4" else 0.0, 4.5) for s, (_, col) in SENSORS.items()}
    print(f"dx = {a.dx * 1000:g} mm; p/(rho g H), impulse in Pa s; error against the experiment's 20 kHz run "
          f"through the same code (2 ms box, {SPAN * 1000:g} ms impulse)\n")
    print("| variant | sensor | raw peak | filtered peak | error | impulse | error | above 1.3x exp. (ms) | wall s |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for s, e in exp.items():
        print(f"| experiment | {s} | {e['raw_max'] / PS:.2f} | {e['filtered_max'] / PS:.2f} | | "
              f"{e['impulse'] or float('nan'):.1f} | | | |")
    with tempfile.TemporaryDirectory() as tmp:
        if a.threads:
            THREADS[:] = ["--threads", str(a.threads)]
        for n in names:
            out = os.path.join(a.keep or tmp, n)
            scene = (scene_with_region(*REGIONS[n], tmp, walls_only=n in WALL_ONLY, scene_h=n in SCENE_H,
                                       split_wall=n in SPLIT_WALL)
                     if n in REGIONS
                     else scene_with_blocks(BLOCKS[n], a.dx, tmp) if n in BLOCKS
                     else "inputs/dam_break_lobovsky.toml")
            if a.surge_probes:
                scene = with_surge_probes(scene, tmp, n)
            summary, failed = run(a.hsph, a.dx, VARIANTS[n], out, scene)
            if summary is None:
                print(f"| {n} | failed: {failed} |||||||")
                continue
            for s, e in exp.items():
                l = summary["pressure_loads"][s]["loads"]
                fe = l["filtered_max"] / e["filtered_max"] - 1
                imp = l["impulse"]
                ie = (imp / e["impulse"] - 1) if imp and e["impulse"] else float("nan")
                over = overshoot_s(out, s, 1.3 * e["filtered_max"]) * 1000
                print(f"| {n} | {s} | {l['raw_max'] / PS:.2f} | {l['filtered_max'] / PS:.2f} | {100 * fe:+.0f} % | "
                      f"{imp or float('nan'):.1f} | {100 * ie:+.0f} % | {over:.1f} | {summary['wall_s']:.0f} |", flush=True)


if __name__ == "__main__":
    main()
