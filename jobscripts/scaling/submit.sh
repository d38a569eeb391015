#!/usr/bin/env bash
# Submits the scaling sweep (dam_break_3d_bench on 1, 2, 4, 8 ranks) and a last job that sets
# the four runs side by side with `hsph report --compare` once all of them have completed:
#   jobscripts/scaling/submit.sh         # from anywhere; the jobs run in the repository root
# The report lands in runs/scaling/report (REPORT.md, plots). HSPH names the binary (default
# target/release/hsph, built with --features mpi); extra arguments go to every sbatch, e.g.
#   jobscripts/scaling/submit.sh --partition compute --account proj
set -euo pipefail
cd "$(dirname "$0")/../.."
hsph=${HSPH:-target/release/hsph}
ids=
runs=
for r in 1 2 4 8; do
    id=$(sbatch --parsable "$@" "jobscripts/scaling/dam_break_3d_bench-r$r.sh")
    echo "dam_break_3d_bench on $r rank(s): job $id"
    ids=$ids:$id
    runs="$runs runs/scaling/dam_break_3d_bench-r$r"
done
id=$(sbatch --parsable "$@" --job-name=hsph-scaling-report --dependency="afterok$ids" \
    --nodes=1 --ntasks=1 --time=00:10:00 --output=hsph-scaling-report-%j.out \
    --wrap="$hsph report --compare$runs --out runs/scaling/report")
echo "report (after the four have completed): job $id -> runs/scaling/report"
