#!/usr/bin/env bash
# Build DualSPHysics (CPU solver) from a snapshot of its public repository, and time it side by side
# with hsph on DualSPHysics's own dam breaks (hsph's copies: inputs/dam_break_2d_dsph.toml,
# inputs/dam_break_3d_dsph.toml). Run from the hsph checkout.
#
#   tools/dualsphysics.sh build GIT_DIR                  extract and compile, once (a few minutes)
#   tools/dualsphysics.sh run 2d|3d THREADS TMAX         one DualSPHysics process: "wall_s peak_KiB"
#   tools/dualsphysics.sh hsph 2d|3d THREADS TMAX [ARGS] one hsph process, the same way
#   tools/dualsphysics.sh vs 2d|3d THREADS TMAX [ROUNDS] [ARGS]
#        ROUNDS (default 3) alternating pairs of whole processes, DualSPHysics then hsph; prints a
#        line per round and a last line "median wall_ratio R rss_ratio S hsph_s H dsph_s D
#        hsph_kib K dsph_kib L" (ratios hsph / DualSPHysics, each the median over rounds).
#        ARGS go to `hsph run` (e.g. --threads is set; add --neighbours cells for the lean mode).
#
# GIT_DIR: the git directory of a snapshot of github.com/DualSPHysics/DualSPHysics (a bare clone
# or a fetched mirror). From commit 1dfd0cd (the last one that ships a GenCase binary) the build
# takes GenCase, the 01_DamBreak example cases and the 5.0 solver; from the snapshot's HEAD the
# newest solver sources (5.4 in 2026), which read GenCase 5.0's cases. Blobs the snapshot lacks
# (Chrono's prebuilt libraries) are skipped, and Chrono, wave generation and MoorDyn+ are off.
# The newest solver is timed unless DSPH_VERSION=5.0. Both codes write no output (-sv:none,
# output.format="none"), so physics alone is timed. Needs g++, make and /usr/bin/time.
# DualSPHysics is LGPL/GPL software: it is built and run here, never copied into hsph.
# Environment: DSPH_HOME (default ~/dsph), DSPH_VERSION, HSPH (default target/release/hsph).
set -euo pipefail

home=${DSPH_HOME:-$HOME/dsph}
hsph_bin=${HSPH:-target/release/hsph}
gencase_rev=1dfd0cd

die() { echo "dualsphysics.sh: $*" >&2; exit 2; }

dsph_case() {
  case $1 in
    2d) echo CaseDambreakVal2D ;;
    3d) echo CaseDambreak ;;
    *) die "dimension is 2d or 3d, not '$1'" ;;
  esac
}

hsph_scene() { echo "inputs/dam_break_$1_dsph.toml"; }

solver() {
  local old=$home/v50/bin/linux/DualSPHysics5.0CPU_linux64 newest
  newest=$(ls "$home"/newest/bin/linux/DualSPHysics*CPU_linux64 2>/dev/null | sort -V | tail -1 || true)
  if [ "${DSPH_VERSION:-newest}" = 5.0 ] || [ -z "$newest" ]; then echo "$old"; else echo "$newest"; fi
}

# extract GIT_DIR REV DEST PATH...: the files of PATHs at REV under DEST, skipping absent blobs
extract() {
  local git=$1 rev=$2 dest=$3; shift 3
  git --git-dir="$git" ls-tree -r "$rev" -- "$@" | while read -r _mode _type blob path; do
    git --git-dir="$git" cat-file -e "$blob" 2>/dev/null || { echo "  skipped (absent): $path" >&2; continue; }
    mkdir -p "$dest/$(dirname "$path")"
    git --git-dir="$git" cat-file blob "$blob" >"$dest/$path"
  done
}

# compile DEST [MAKE VARIABLES...]: the CPU solver of the sources under DEST
compile() {
  local dest=$1; shift
  (cd "$dest/src/source" && make -f Makefile_cpu -j"$(nproc)" USE_GCC5=YES COMPILE_CHRONO=NO \
    COMPILE_CHRONO_OMP=NO "$@" >"$dest/build.log" 2>&1)
}

build() {
  local git=${1:?GIT_DIR}
  command -v g++ >/dev/null && command -v make >/dev/null || die "needs g++ and make (apt-get install g++ make)"
  git --git-dir="$git" cat-file -e "$gencase_rev^{commit}" 2>/dev/null || die "$git has no commit $gencase_rev"
  echo "DualSPHysics 5.0 and GenCase from $gencase_rev into $home/v50"
  extract "$git" "$gencase_rev" "$home/v50" src/source src/lib/linux_gcc bin/linux/GenCase_linux64 \
    bin/linux/DsphConfig.xml examples/main/01_DamBreak
  compile "$home/v50" || { tail -20 "$home/v50/build.log"; exit 1; }
  chmod +x "$home/v50/bin/linux/GenCase_linux64"
  echo "the newest solver from $(git --git-dir="$git" rev-parse --short HEAD) into $home/newest"
  extract "$git" HEAD "$home/newest" src/source src/lib/linux_gcc
  mkdir -p "$home/newest/bin/linux"
  compile "$home/newest" COMPILE_WAVEGEN=NO COMPILE_MOORDYNPLUS=NO ||
    echo "the newest solver did not build ($home/newest/build.log): 5.0 is timed" >&2
  mkdir -p "$home/cases"
  local c
  for c in CaseDambreakVal2D CaseDambreak; do
    cp "$home/v50/examples/main/01_DamBreak/${c}_Def.xml" "$home/cases/"
    (cd "$home/cases" && "$home/v50/bin/linux/GenCase_linux64" "${c}_Def" "gen_$c/$c" -save:all >"gen_$c.log" 2>&1)
    grep -m1 "Total particles" "$home/cases/gen_$c.log" || true
  done
  echo "timed solver: $(solver)"
}

# timed CMD...: runs one whole process, prints "wall_s peak_KiB"
timed() {
  local t
  t=$(mktemp)
  /usr/bin/time -f "%e %M" -o "$t" "$@" >/dev/null 2>&1 || { rm -f "$t"; die "failed: $*"; }
  cat "$t"; rm -f "$t"
}

run_dsph() {
  local dim=$1 threads=$2 tmax=$3 c s out
  c=$(dsph_case "$dim"); s=$(solver)
  [ -x "$s" ] || die "no DualSPHysics solver under $home: run tools/dualsphysics.sh build GIT_DIR first"
  out=$(mktemp -d)
  (cd "$home/cases" && timed "$s" "gen_$c/$c" "$out" -sv:none -ompthreads:"$threads" -tmax:"$tmax")
  rm -rf "$out"
}

run_hsph() {
  local dim=$1 threads=$2 tmax=$3 out; shift 3
  [ -x "$hsph_bin" ] || die "no $hsph_bin: cargo build --release first (or set HSPH)"
  out=$(mktemp -d)
  timed "$hsph_bin" run "$(hsph_scene "$dim")" --threads "$threads" --set time.t_end="$tmax" \
    --set 'output.format="none"' --out "$out/run" -q "$@"
  rm -rf "$out"
}

vs() {
  local dim=$1 threads=$2 tmax=$3 rounds=3 k d h dw dm hw hm pairs
  shift 3
  if [ $# -gt 0 ] && [[ $1 =~ ^[0-9]+$ ]]; then rounds=$1; shift; fi
  [ -x "$(solver)" ] || die "no DualSPHysics solver under $home: run tools/dualsphysics.sh build GIT_DIR first"
  [ -x "$hsph_bin" ] || die "no $hsph_bin: cargo build --release first (or set HSPH)"
  pairs=$(mktemp)
  echo "peer: $(basename "$(solver)"); hsph: $hsph_bin $*"
  for k in $(seq "$rounds"); do
    d=$(run_dsph "$dim" "$threads" "$tmax")
    h=$(run_hsph "$dim" "$threads" "$tmax" "$@")
    read -r dw dm <<<"$d"
    read -r hw hm <<<"$h"
    echo "round $k: DualSPHysics $dw s $dm KiB, hsph $hw s $hm KiB"
    echo "$hw $dw $hm $dm" >>"$pairs"
  done
  python3 - "$pairs" <<'PY'
import statistics, sys
rows = [[float(x) for x in line.split()] for line in open(sys.argv[1])]
med = lambda xs: statistics.median(xs)
print("median wall_ratio %.3f rss_ratio %.2f hsph_s %.2f dsph_s %.2f hsph_kib %d dsph_kib %d" % (
    med([h / d for h, d, _, _ in rows]), med([h / d for _, _, h, d in rows]),
    med([r[0] for r in rows]), med([r[1] for r in rows]), med([r[2] for r in rows]), med([r[3] for r in rows])))
PY
  rm -f "$pairs"
}

cmd=${1:-}
[ $# -gt 0 ] && shift
case $cmd in
  build) build "$@" ;;
  run) [ $# -eq 3 ] || die "run 2d|3d THREADS TMAX"; run_dsph "$@" ;;
  hsph) [ $# -ge 3 ] || die "hsph 2d|3d THREADS TMAX [ARGS]"; run_hsph "$@" ;;
  vs) [ $# -ge 3 ] || die "vs 2d|3d THREADS TMAX [ROUNDS] [ARGS]"; vs "$@" ;;
  *) sed -n '2,22p' "$0"; exit 2 ;;
esac
