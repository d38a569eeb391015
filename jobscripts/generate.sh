#!/usr/bin/env bash
# Regenerates the job scripts in jobscripts/ with `hsph jobscript` (an hsph built with
# `cargo build --release --features mpi`): one per shipped scene in inputs/, with a layout that
# suits its size, and the scaling sweep in jobscripts/scaling/ (1, 2, 4, 8 ranks).
#   jobscripts/generate.sh                       # uses target/release/hsph
#   HSPH=/path/to/hsph jobscripts/generate.sh
# The generator writes absolute paths (scene, run directory, binary); this keeps the scripts
# relative to the repository root instead, so that they work in any clone: submit them from
# there (`sbatch jobscripts/dam_break_3d.sh`), and set HSPH when the binary lives elsewhere.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
hsph=${HSPH:-target/release/hsph}
[ -x "$hsph" ] || { echo "generate.sh: no hsph at $hsph: cargo build --release --features mpi, or set HSPH" >&2; exit 2; }
bin=$(realpath "$hsph") # what the generator names as the binary (its own path)

# gen SCRIPT SCENE [hsph jobscript flags...]
gen() {
    local script=$1 scene=$2
    shift 2
    "$hsph" jobscript "$scene" --script "$script.tmp" "$@" >/dev/null
    sed -e "s|^HSPH=\"\${HSPH:-$bin}\"\$|HSPH=\"\${HSPH:-target/release/hsph}\"|" \
        -e "s|\"$root/|\"|g" "$script.tmp" >"$script"
    rm -f "$script.tmp"
    if grep -q "$root" "$script"; then
        echo "generate.sh: $script still names $root" >&2
        exit 1
    fi
    chmod 755 "$script"
    echo "$script"
}

# Small 2D scenes: one node; the periodic channels (525 particles) stay on one rank.
gen jobscripts/couette_2d.sh inputs/couette_2d.toml --out runs/couette_2d \
    --nodes 1 --ranks-per-node 1 --threads-per-rank 4 --time 00:15:00
gen jobscripts/poiseuille_2d.sh inputs/poiseuille_2d.toml --out runs/poiseuille_2d \
    --nodes 1 --ranks-per-node 1 --threads-per-rank 4 --time 00:15:00
gen jobscripts/hydrostatic_2d.sh inputs/hydrostatic_2d.toml --out runs/hydrostatic_2d \
    --nodes 1 --ranks-per-node 2 --threads-per-rank 2 --time 00:15:00
gen jobscripts/dam_break_2d.sh inputs/dam_break_2d.toml --out runs/dam_break_2d \
    --nodes 1 --ranks-per-node 2 --threads-per-rank 2 --time 00:15:00
# 23 000 and 25 000 particles: one node of 4 ranks × 4 threads; the 3D dam break on two nodes.
gen jobscripts/dam_break_2d_dsph.sh inputs/dam_break_2d_dsph.toml --out runs/dam_break_2d_dsph \
    --nodes 1 --ranks-per-node 4 --threads-per-rank 4 --time 00:30:00
gen jobscripts/dam_break_3d.sh inputs/dam_break_3d.toml --out runs/dam_break_3d \
    --nodes 2 --ranks-per-node 4 --threads-per-rank 4 --time 01:00:00
# 275 000 particles, ~150 steps (the benchmark): four nodes.
gen jobscripts/dam_break_3d_bench.sh inputs/dam_break_3d_bench.toml --out runs/dam_break_3d_bench \
    --nodes 4 --ranks-per-node 8 --threads-per-rank 4 --time 00:15:00
# 302 000 particles to t = 1.6 s (about 18 600 steps): DualSPHysics's CaseDambreak on four nodes.
gen jobscripts/dam_break_3d_dsph.sh inputs/dam_break_3d_dsph.toml --out runs/dam_break_3d_dsph \
    --nodes 4 --ranks-per-node 8 --threads-per-rank 4 --time 06:00:00

# Scaling sweep: the benchmark scene on 1, 2, 4, 8 ranks of one node, one thread each; the run
# directories feed `hsph report --compare` (jobscripts/scaling/submit.sh does both).
for r in 1 2 4 8; do
    gen "jobscripts/scaling/dam_break_3d_bench-r$r.sh" inputs/dam_break_3d_bench.toml \
        --out "runs/scaling/dam_break_3d_bench-r$r" \
        --nodes 1 --ranks-per-node "$r" --threads-per-rank 1 --time 00:30:00
done
