#!/usr/bin/env bash
# Rebuilds an experiment folder under runs/ from its committed compact cells after the machine
# lost runs/ (sessions may start on a fresh machine): marks the folder as an experiment and each
# finished cell as a run, copies its compact record (cell.toml, results.json, report.md, ...).
# `joca experiment` run on the folder afterwards checks every restored cell.toml against the
# grid (it refuses a cell made with another configuration) and runs only the missing cells.
# Usage: restore.sh COMPACT_CELLS_DIR RUN_DIR
#   e.g. restore.sh docs/results/2026-11-27-panels/perturbation/cells runs/pert-panel
set -euo pipefail
src=${1:?compact cells folder}
dest=${2:?experiment folder under runs/}
mkdir -p "$dest/cells"
[ -f "$dest/.joca-output" ] || printf 'joca-output experiment\n' > "$dest/.joca-output"
n=0
for d in "$src"/*/; do
  id=$(basename "$d")
  [ -f "$d/results.json" ] || continue
  cell="$dest/cells/$id"
  if [ -f "$cell/results.json" ]; then continue; fi
  mkdir -p "$cell"
  cp -r "$d"/. "$cell/"
  printf 'joca-output run\n' > "$cell/.joca-output"
  n=$((n + 1))
done
echo "restored $n finished cells into $dest"
