#!/usr/bin/env python3
"""Render BENCHMARKS.md from the recorded runs in docs/bench/records.csv.

Usage (from anywhere in the repository; python3 standard library only):

    python3 tools/bench_render.py            # mark stale records from git, then write BENCHMARKS.md
    python3 tools/bench_render.py --check    # exit 1 unless BENCHMARKS.md is the records' rendering

A record is *stale* when the code it describes differs from the code at its commit: a line that
is not a comment changed, between the record's commit and HEAD, in src/, Cargo.toml, Cargo.lock,
build.rs or the record's scene file (inputs/<scene>.toml). Comment-only changes (`//` in Rust,
`#` in TOML) keep a record current. The flag is stored in the `stale` column, so `--check` needs
no git history (a shallow or exported copy checks the same); the render command recomputes it
where git knows the record's commit and keeps the stored flag where it does not.
"""
import csv
import io
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RECORDS = os.path.join(ROOT, "docs", "bench", "records.csv")
PAGE = os.path.join(ROOT, "BENCHMARKS.md")
MAX_LINES = 300
CODE = ["src", "Cargo.toml", "Cargo.lock", "build.rs"]

SCENES = {
    "dam_break_2d_dsph": "DualSPHysics's 2D dam break (`inputs/dam_break_2d_dsph.toml`, 23 018 particles)",
    "dam_break_3d_dsph": "DualSPHysics's 3D CaseDambreak (`inputs/dam_break_3d_dsph.toml`, 264 k particles)",
    "dam_break_lobovsky": "Lobovsky's dam break (`inputs/dam_break_lobovsky.toml`, 9 144 particles)",
    "dam_break_lobovsky_adaptive": "Lobovsky's dam break, adaptive (`inputs/dam_break_lobovsky_adaptive.toml`)",
    "solitary_wave_adaptive": "The solitary wave, adaptive (`inputs/solitary_wave_adaptive.toml`)",
    "impact_oblique_45": "The oblique impact (`inputs/impact_oblique_45.toml`, 73 k particles)",
}

HEAD = """# Benchmarks

<!-- Rendered by `python3 tools/bench_render.py` from docs/bench/records.csv: edit the records, not this page. -->

The newest recorded figures: for each benchmark scene, mode and thread count, hsph against
DualSPHysics (the reference peer, whole processes side by side on the same machine), against
the baseline `7c0305b` (hsph before its speed work) or, for an adaptive scene, against the
uniform fine run it replaces. A ratio is hsph's figure over the other's: below 1, hsph is faster
or smaller. Each row gives the commit, date and machine it was measured on; its command, machine
and the section of [docs/benchmark-log.md](docs/benchmark-log.md) that tells how it was taken are
listed under its table. That log keeps every measurement session, newest first.

## Commands

- **Render** this page: `python3 tools/bench_render.py` (python3, standard library). It marks
  the stale records in `docs/bench/records.csv` from git and writes BENCHMARKS.md; `--check`
  only compares (the test `docs::benchmarks_page_is_the_rendering_of_its_records` runs it).
- **Rerun** the recorded comparisons: `python3 tools/bench_rerun.py [--rounds N] [NAME...]`
  (`--list` shows what it would run). It times DualSPHysics beside hsph with
  `tools/dualsphysics.sh` (build DualSPHysics once: `tools/dualsphysics.sh build GIT_DIR`),
  replaces the records it measured (command, commit, machine, date), adds their section to the
  log and renders this page. Nothing else may run on the machine meanwhile.
- **Stale**: a record is stale when a line that is not a comment changed in `src/`,
  `Cargo.toml`, `Cargo.lock`, `build.rs` or its scene file between its commit and the commit the
  page was rendered at. A stale figure describes older code: rerun it before quoting it.

## Modes

- **default**: the scene as shipped. The 2D scene ships pair mode with Verlet lists (skin 0.03)
  and Fourtakas's density diffusion; the 3D scene pair mode with Verlet lists and Antuono's
  diffusion with the lagged gradient.
- **fast** (3D): `--interactions pairs --neighbours verlet --set performance.skin=0.03 --set
  physics.density_diffusion="fourtakas" --set physics.density_gradient="step"`.
- **lean** (3D): no stored lists, `--neighbours cells` with Fourtakas's diffusion.
- **pairs, lists**: pair mode with neighbour lists rebuilt every step, the mode of the baseline
  comparison.
"""


def read_records(path=RECORDS):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def write_records(rows, path=RECORDS):
    out = io.StringIO()
    w = csv.DictWriter(out, fieldnames=list(rows[0].keys()), lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow(r)
    with open(path, "w", newline="") as f:
        f.write(out.getvalue())


def git(*args):
    return subprocess.run(["git", "-C", ROOT, *args], capture_output=True, text=True)


def scene_file(scene):
    """The record's scene file: inputs/<scene>.toml, or docs/bench/<scene>.toml for a scene
    made for a benchmark only."""
    bench = os.path.join("docs", "bench", scene + ".toml")
    return bench if os.path.exists(bench) else os.path.join("inputs", scene + ".toml")


def code_changed(commit, scene):
    """True if a non-comment line of the code or the scene changed since `commit`; None if git
    cannot tell (no git, or the commit is not in this history)."""
    if git("cat-file", "-e", commit + "^{commit}").returncode != 0:
        return None
    paths = CODE + [scene_file(scene)]
    d = git("diff", "--unified=0", "--no-color", commit, "HEAD", "--", *paths)
    if d.returncode != 0:
        return None
    toml = False
    for line in d.stdout.splitlines():
        if line.startswith("diff --git"):
            toml = line.endswith(".toml")
            continue
        if line.startswith(("+++", "---")) or not line[:1] in ("+", "-"):
            continue
        text = line[1:].strip()
        if not text or text.startswith("#" if toml else "//"):
            continue
        return True
    return False


def mark_stale(rows):
    for r in rows:
        changed = code_changed(r["commit"], r["scene"])
        if changed is None:
            print(f"{r['id']}: git does not know {r['commit']}; stale flag kept", file=sys.stderr)
        else:
            r["stale"] = "stale" if changed else ""
    return rows


def cell(v):
    return v.replace("|", "\\|") if v else "—"


def figure(value, unit):
    return f"{value} {unit}" if value else "—"


def render(rows):
    out = [HEAD]
    scenes = []
    for r in rows:
        if r["scene"] not in scenes:
            scenes.append(r["scene"])
    n = 0
    for s in scenes:
        out.append(f"## {s}\n")
        out.append(SCENES.get(s, f"`{scene_file(s)}`") + ".\n")
        out.append("| # | mode | threads | span | quantity | hsph | against | its figure | ratio | commit | date | status |")
        out.append("|---|---|---|---|---|---|---|---|---|---|---|---|")
        notes = []
        for r in (r for r in rows if r["scene"] == s):
            n += 1
            ratio = f"**{r['ratio']}**" if r["ratio"] else "—"
            status = "**stale**" if r["stale"] else "current"
            out.append(
                f"| {n} | {cell(r['mode'])} | {r['threads']} | {r['span']} | {r['quantity']} | "
                f"{figure(r['hsph'], r['unit'])} | {cell(r['against'])} | "
                f"{figure(r['against_value'], r['unit'])} | {ratio} | `{r['commit']}` | {r['date']} | {status} |"
            )
            rounds = "1 round" if r["rounds"] == "1" else f"{r['rounds']} rounds, medians"
            note = f"`{r['command']}`; {r['machine']}; {rounds}; log: \"{r['log']}\"."
            if notes and notes[-1][1] == note:
                notes[-1][0].append(n)
            else:
                notes.append(([n], note))
        out.append("")
        for ns, note in notes:
            out.append(f"- {', '.join(map(str, ns))}: {note}")
        out.append("")
    return "\n".join(out).rstrip("\n") + "\n"


def main(argv):
    check = "--check" in argv[1:]
    rows = read_records()
    if check:
        text = render(rows)
        with open(PAGE) as f:
            page = f.read()
        lines = page.count("\n")
        if page != text:
            print("BENCHMARKS.md is not the rendering of docs/bench/records.csv: "
                  "run python3 tools/bench_render.py", file=sys.stderr)
            return 1
        if lines > MAX_LINES:
            print(f"BENCHMARKS.md has {lines} lines, more than {MAX_LINES}", file=sys.stderr)
            return 1
        return 0
    rows = mark_stale(rows)
    write_records(rows)
    text = render(rows)
    with open(PAGE, "w") as f:
        f.write(text)
    lines = text.count("\n")
    print(f"BENCHMARKS.md: {len(rows)} records, {lines} lines, "
          f"{sum(1 for r in rows if r['stale'])} stale")
    return 0 if lines <= MAX_LINES else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
