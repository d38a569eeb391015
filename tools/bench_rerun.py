#!/usr/bin/env python3
"""Rerun the recorded benchmark comparisons and record them (docs/bench/records.csv).

Usage, from the hsph checkout after `cargo build --release` (python3 standard library only):

    python3 tools/bench_rerun.py --list                 # the comparisons, by name
    python3 tools/bench_rerun.py [--rounds N] [--baseline-bin PATH] [NAME...]

Each comparison is whole processes alternating on this machine, N rounds (default 3), medians:
the DualSPHysics dam breaks through `tools/dualsphysics.sh vs` (build DualSPHysics first with
`tools/dualsphysics.sh build GIT_DIR`), the adaptive scenes against their uniform fine runs, the
impact alone, and, given `--baseline-bin` (hsph built at `7c0305b`), the baseline comparisons.
Its records (wall time and peak RSS) replace the records of the same scene, mode, thread count,
quantity and kind of comparison; the commit, date and machine are this checkout's and this
machine's. The rounds are written as a new section at the top of docs/benchmark-log.md, and
BENCHMARKS.md is rendered again (tools/bench_render.py). Nothing else should run meanwhile.
"""
import datetime
import os
import statistics
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_render  # noqa: E402

ROOT = bench_render.ROOT
LOG = os.path.join(ROOT, "docs", "benchmark-log.md")
HSPH = os.environ.get("HSPH", "target/release/hsph")
FAST = ["--interactions", "pairs", "--neighbours", "verlet", "--set", "performance.skin=0.03",
        "--set", 'physics.density_diffusion="fourtakas"', "--set", 'physics.density_gradient="step"']
LEAN = ["--neighbours", "cells", "--set", 'physics.density_diffusion="fourtakas"',
        "--set", 'physics.density_gradient="step"']
SOLITARY_UNIFORM = ["inputs/solitary_wave.toml", "--set", "fluid[0].max=[10.0,0.24]",
                    "--set", "wall[1].motion.amplitude=0.048", "--set", "wall[1].motion.depth=0.24"]


def dsph(dim, mode, threads, tmax, args):
    return dict(kind="dsph", name=f"{dim}-{mode}-{threads}t", dim=dim, mode=mode, threads=threads,
                tmax=tmax, args=args, scene=f"dam_break_{dim}_dsph", span=f"{tmax} s")


def pair(name, scene, mode, threads, span, hsph_args, other, other_args, baseline=False):
    return dict(kind="pair", name=name, scene=scene, mode=mode, threads=threads, span=span,
                args=hsph_args, other=other, other_args=other_args, baseline=baseline)


COMPARISONS = [
    dsph("2d", "default", 1, 0.2, []),
    dsph("2d", "default", 2, 0.2, []),
    dsph("3d", "default", 1, 0.02, []),
    dsph("3d", "default", 2, 0.02, []),
    dsph("3d", "fast", 1, 0.02, FAST),
    dsph("3d", "fast", 2, 0.02, FAST),
    dsph("3d", "lean", 2, 0.02, LEAN),
    pair("lobovsky-adaptive-1t", "dam_break_lobovsky_adaptive", "default (local steps)", 1, "whole run",
         ["inputs/dam_break_lobovsky_adaptive.toml"], "uniform 5 mm run", ["inputs/dam_break_lobovsky.toml"]),
    pair("solitary-adaptive-1t", "solitary_wave_adaptive", "default (band 0.32 m, local steps)", 1, "whole run",
         ["inputs/solitary_wave_adaptive.toml"], "uniform 1 cm run", SOLITARY_UNIFORM),
    pair("impact-1t", "impact_oblique_45", "default", 1, "5 µs (507 steps)",
         ["inputs/impact_oblique_45.toml", "--set", "time.t_end=5e-6"], "", None),
    pair("impact-2t", "impact_oblique_45", "default", 2, "5 µs (507 steps)",
         ["inputs/impact_oblique_45.toml", "--set", "time.t_end=5e-6"], "", None),
    pair("2d-pairs-1t-base", "dam_break_2d_dsph", "pairs, lists", 1, "0.2 s",
         ["inputs/dam_break_2d_dsph.toml", "--interactions", "pairs", "--neighbours", "lists"],
         "baseline 7c0305b", ["inputs/dam_break_2d_dsph.toml"], baseline=True),
    pair("2d-pairs-2t-base", "dam_break_2d_dsph", "pairs, lists", 2, "0.2 s",
         ["inputs/dam_break_2d_dsph.toml", "--interactions", "pairs", "--neighbours", "lists"],
         "baseline 7c0305b", ["inputs/dam_break_2d_dsph.toml"], baseline=True),
]


def sh(cmd):
    return " ".join(a if a.replace("/", "").replace(".", "").replace("-", "").replace("_", "").replace("=", "").isalnum()
                    else "'" + a + "'" for a in cmd)


def timed(cmd):
    """One whole process under /usr/bin/time: (wall s, peak KiB)."""
    tf = "/tmp/bench_rerun_time.txt"
    subprocess.run(["/usr/bin/time", "-f", "%e %M", "-o", tf, *cmd], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT)
    w, k = open(tf).read().split()[-2:]
    return float(w), int(k)


def hsph_run(binary, args, threads):
    out = subprocess.run(["mktemp", "-d"], capture_output=True, text=True, check=True).stdout.strip()
    try:
        return timed([binary, "run", *args, "--threads", str(threads), "--set", 'output.format="none"',
                      "--out", os.path.join(out, "run"), "-q"])
    finally:
        subprocess.run(["rm", "-rf", out])


def machine():
    model = "unknown CPU"
    try:
        for line in subprocess.run(["lscpu"], capture_output=True, text=True).stdout.splitlines():
            if line.startswith("Model name:"):
                model = line.split(":", 1)[1].strip()
        mem = next(l for l in open("/proc/meminfo") if l.startswith("MemTotal")).split()[1]
        gib = round(int(mem) / 2**20)
        load = open("/proc/loadavg").read().split()[0]
    except (OSError, StopIteration):
        gib, load = "?", "?"
    return f"{os.cpu_count()} cores ({model}), {gib} GiB, load {load} at the start"


def run(c, rounds, baseline_bin, lines):
    """The comparison's records (wall time, peak RSS), and its rounds appended to `lines`."""
    if c["kind"] == "dsph":
        cmd = ["tools/dualsphysics.sh", "vs", c["dim"], str(c["threads"]), str(c["tmax"]), str(rounds), *c["args"]]
        p = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env=dict(os.environ, HSPH=HSPH))
        if p.returncode != 0:
            raise SystemExit(f"{sh(cmd)} failed:\n{p.stderr}")
        out = p.stdout.strip().splitlines()
        lines += [f"`{sh(cmd)}`:", "", "```", *out, "```", ""]
        peer = out[0].split()[1]
        version = peer.replace("DualSPHysics", "").split("CPU")[0] or "?"
        m = dict(zip(out[-1].split()[1::2], out[-1].split()[2::2]))
        against = f"DualSPHysics {version}"
        return cmd, against, [("wall time", "s", m["hsph_s"], m["dsph_s"], m["wall_ratio"]),
                              ("peak RSS", "KiB", m["hsph_kib"], m["dsph_kib"], m["rss_ratio"])]
    if c["baseline"] and not baseline_bin:
        return None
    other_bin = baseline_bin if c["baseline"] else HSPH
    rows = []
    for k in range(rounds):
        h = hsph_run(HSPH, c["args"], c["threads"])
        o = hsph_run(other_bin, c["other_args"], c["threads"]) if c["other_args"] else None
        rows.append((h, o))
        lines.append(f"- round {k + 1}: hsph {h[0]} s {h[1]} KiB" + (f", {c['other']} {o[0]} s {o[1]} KiB" if o else ""))
    lines.append("")
    med = statistics.median
    hw, hk = med(r[0][0] for r in rows), med(r[0][1] for r in rows)
    cmd = [HSPH, "run", *c["args"], "--threads", str(c["threads"]), "--set", 'output.format="none"']
    if c["other_args"] is None:
        return cmd, "", [("wall time", "s", f"{hw:.2f}", "", ""), ("peak RSS", "KiB", f"{hk:.0f}", "", "")]
    ow, ok = med(r[1][0] for r in rows), med(r[1][1] for r in rows)
    wr, kr = med(r[0][0] / r[1][0] for r in rows), med(r[0][1] / r[1][1] for r in rows)
    cmd += ["; against:", other_bin, "run", *c["other_args"], "--threads", str(c["threads"])]
    return cmd, c["other"], [("wall time", "s", f"{hw:.2f}", f"{ow:.2f}", f"{wr:.3f}"),
                             ("peak RSS", "KiB", f"{hk:.0f}", f"{ok:.0f}", f"{kr:.2f}")]


def main(argv):
    args, rounds, baseline_bin, names = argv[1:], 3, None, []
    while args:
        a = args.pop(0)
        if a == "--list":
            for c in COMPARISONS:
                print(c["name"], "(needs --baseline-bin)" if c.get("baseline") else "")
            return 0
        if a == "--rounds":
            rounds = int(args.pop(0))
        elif a == "--baseline-bin":
            baseline_bin = os.path.abspath(args.pop(0))
        else:
            names.append(a)
    chosen = [c for c in COMPARISONS if not names or c["name"] in names]
    if names and len(chosen) != len(names):
        raise SystemExit(f"unknown comparison in {names}; see --list")
    commit = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short=7", "HEAD"], capture_output=True, text=True).stdout.strip()
    date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d")
    mach = machine()
    title = f"Rerun of the recorded comparisons at `{commit}`, {date}"
    lines = [f"## {title}", "", f"`python3 tools/bench_rerun.py --rounds {rounds}`, {mach}, hsph `{HSPH}`.", ""]
    records = bench_render.read_records()
    fresh = []
    for c in chosen:
        print(f"{c['name']} ...", flush=True)
        lines.append(f"**{c['name']}**")
        lines.append("")
        got = run(c, rounds, baseline_bin, lines)
        if got is None:
            lines.append("skipped: no `--baseline-bin`")
            lines.append("")
            continue
        cmd, against, figures = got
        for q, unit, h, o, r in figures:
            fresh.append(dict(
                id=f"{c['name']}-{'wall' if q == 'wall time' else 'rss'}-{against.split(' ')[0].lower() if against else 'alone'}",
                scene=c["scene"], mode=c["mode"], threads=str(c["threads"]), span=c["span"], quantity=q, unit=unit,
                hsph=h, against=against, against_value=o, ratio=r, rounds=str(rounds), commit=commit, date=date,
                machine=mach, command=sh(cmd), log=title, stale=""))
    family = lambda r: (r["scene"], r["mode"], r["threads"], r["quantity"], r["against"].split(" ")[0])
    new = {family(r) for r in fresh}
    records = [r for r in records if family(r) not in new] + fresh
    bench_render.write_records(records)
    text = open(LOG).read()
    i = text.index("\n## ") + 1
    open(LOG, "w").write(text[:i] + "\n".join(lines) + "\n" + text[i:])
    return bench_render.main(["bench_render.py"])


if __name__ == "__main__":
    sys.exit(main(sys.argv))
