#!/usr/bin/env bash
# Copies an experiment's finished cells (compact records) into docs/results and writes its report
# from them as they stand (`joca report` on a copy without checkpoints, so the running cells are
# not touched). Usage: land.sh [JOCA_BINARY [RUN_DIR DEST_DIR [RESULTS]]] (defaults
# target/release/joca, the perturbation panel: runs/pert-panel into
# docs/results/2026-11-27-panels/perturbation). With RESULTS (e.g. results-town2.json, written by
# eval_town.sh), the report is of those tests instead, over the cells that have them:
# DEST_DIR/report-town2.md and results-town2.csv. RESULTS `both`: results.json, then
# results-town2.json where any cell has it.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../../.."
bin=${1:-target/release/joca}
src=${2:-runs/pert-panel}
dest=${3:-docs/results/2026-11-27-panels/perturbation}
results=${4:-results.json}
if [ "$results" = both ]; then # the test town, then town 2 over the cells that have it
  "$0" "$bin" "$src" "$dest" results.json
  if ls "$src"/cells/*/results-town2.json > /dev/null 2>&1; then
    "$0" "$bin" "$src" "$dest" results-town2.json
  fi
  exit
fi
tag=${results#results}
tag=${tag%.json}
python3 docs/results/2026-11-27-detector-input/compact.py "$src" "$dest"
tmp=$(mktemp -d)
cp "$src/experiment.json" "$src/.joca-output" "$tmp/" 2>/dev/null || cp "$src/experiment.json" "$tmp/"
mkdir -p "$tmp/cells"
for d in "$src"/cells/*/; do
  id=$(basename "$d")
  [ -f "$d/$results" ] || continue
  mkdir -p "$tmp/cells/$id"
  for f in "$d"/*; do [ "$(basename "$f")" = checkpoint ] || cp -r "$f" "$tmp/cells/$id/"; done
  cp "$d/$results" "$tmp/cells/$id/results.json"
  cp "$d"/.joca-output "$tmp/cells/$id/" 2>/dev/null || true
done
"$bin" report "$tmp" >/dev/null
# The figures change at every landing, so they are committed once, when a grid is complete
# (FIGURES=1: beside the report, figures/ for the test town, figures-town2/ for town 2); until
# then the report leaves out each figure and its caption and says so.
if [ -n "${FIGURES:-}" ]; then
  sed -e "s#$tmp#$src#g" -e "s#(figures/#(figures$tag/#g" "$tmp/report.md" > "$dest/report$tag.md"
  rm -rf "$dest/figures$tag"
  cp -r "$tmp/figures" "$dest/figures$tag"
  # Another test's figures keep only those that differ from the test town's (the frames): the
  # rest (fitness, loss, settings, ...) come from training and are the same files, linked there.
  if [ -n "$tag" ] && [ -d "$dest/figures" ]; then
    for f in "$dest/figures$tag"/*; do
      b=$(basename "$f")
      cmp -s "$f" "$dest/figures/$b" || continue
      rm "$f"
      sed -i "s#figures$tag/$b)#figures/$b)#g; s#figures$tag/$b\]#figures/$b]#g" \
        "$dest/report$tag.md"
    done
  fi
else
  sed "s#$tmp#$src#g" "$tmp/report.md" \
    | awk -v src="$src" -f docs/results/2026-11-27-panels/strip_figures.awk \
    > "$dest/report$tag.md"
fi
cp "$tmp/results.csv" "$dest/results$tag.csv"
rm -rf "$tmp"
echo "landed $(ls "$dest"/cells | wc -l) cells; report: $dest/report$tag.md"
