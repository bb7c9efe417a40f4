#!/usr/bin/env bash
# The wide normals benchmark in one command: builds bench_normals, runs --wide --speed
# (2 threads; about 40 min on the shared 2-core machine), draws the normals_wide_*.png charts into
# docs/results/normals/ and writes the run's CSV, log and generated tables into bench/results/normals/
# (not tracked): fold them into docs/results/normals/normals.csv and summary.md by hand.
# Usage: bash bench/normals/run_wide.sh [build-dir] [extra bench_normals options]
# A full run also keeps its CGAL rows in bench/results/normals/normals_wide_peers.csv; a rerun with
# --no-cgal (about 12 min instead of 40, for a change of the class) borrows them for the summary (same
# clouds, same seed), else the jet_* / vcm_* rows of docs/results/normals/normals.csv.
set -euo pipefail
cd "$(dirname "$0")/../.."
BUILD=${1:-build-nbench}
shift || true
OUT=docs/results/normals
RUN=bench/results/normals
mkdir -p "$RUN"
if [ ! -f "$BUILD/build.ninja" ] && [ ! -f "$BUILD/Makefile" ]; then
  cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPCLX_BUILD_DRIVERS=OFF -DPCLX_BUILD_APPS=OFF
fi
cmake --build "$BUILD" -j2 --target bench_normals
# NORMALS_COMMIT names the class commit when this runs from an exported tree (git archive) without .git.
COMMIT=${NORMALS_COMMIT:-$(git log -1 --format=%h -- modules/normals 2>/dev/null || echo unknown)}
# What the bench compiles of the class: its headers and sources (not its tests).
DIRTY=$(git status --porcelain -- modules/normals/include modules/normals/src modules/normals/CMakeLists.txt \
  2>/dev/null | grep -q . && echo " + uncommitted changes" || true)
echo "[run_wide] modules/normals at $COMMIT$DIRTY; started $(date -u +%H:%M) UTC" >&2
start=$(date +%s)
"$BUILD/bench/normals/bench_normals" --wide --speed --threads 2 --csv "$RUN/normals_wide.csv" "$@" \
  > /dev/null 2> >(tee "$RUN/normals_wide.log" >&2)
echo "[run_wide] bench wall time $(( $(date +%s) - start )) s" | tee -a "$RUN/normals_wide.log" >&2
PEERS=()
if grep -q '^normals,jet_' "$RUN/normals_wide.csv"; then
  grep -E '^(module|normals,(jet|vcm)_)' "$RUN/normals_wide.csv" > "$RUN/normals_wide_peers.csv"
else
  if [ ! -f "$RUN/normals_wide_peers.csv" ] && grep -q '^normals,jet_' "$OUT/normals.csv" 2>/dev/null; then
    grep -E '^(module|normals,(jet|vcm)_)' "$OUT/normals.csv" > "$RUN/normals_wide_peers.csv"
  fi
  if [ -f "$RUN/normals_wide_peers.csv" ]; then
    PEERS=(--peers-from "$RUN/normals_wide_peers.csv")
  fi
fi
/usr/bin/python3 bench/normals/normals_wide_charts.py "$RUN/normals_wide.csv" "${PEERS[@]}" --out "$OUT"
/usr/bin/python3 bench/normals/normals_wide_summary.py "$RUN/normals_wide.csv" --commit "$COMMIT$DIRTY" \
  "${PEERS[@]}" --out "$RUN/normals_wide_summary.md" > /dev/null
echo "[run_wide] wrote $OUT/normals_wide_*.png and $RUN/normals_wide.csv, normals_wide.log, normals_wide_summary.md" >&2
