#!/usr/bin/env bash
# Copies an experiment's finished cells (compact records) into docs/results and writes its report
# from them as they stand (`joca report` on a copy without checkpoints, so the running cells are
# not touched). Usage: land.sh [JOCA_BINARY [RUN_DIR DEST_DIR [RESULTS]]] (defaults
# target/release/joca, the perturbation panel: runs/pert-panel into
# docs/results/2026-11-27-panels/perturbation). With RESULTS (e.g. results-town2.json, written by
# eval_town.sh), the report is of those tests instead, over the cells that have them:
# DEST_DIR/report-town2.md and results-town2.csv. RESULTS `both`: results.json, then
# results-town2.json where any cell has it. Without FIGURES, a landing with no new cell result
# leaves the landed reports (and their committed figures) as they are.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../../.."
bin=${1:-target/release/joca}
src=${2:-runs/pert-panel}
dest=${3:-docs/results/2026-11-27-panels/perturbation}
results=${4:-results.json}
# Whether every finished cell's RESULTS landed already, byte for byte, and without FIGURES: then
# the landed report stays as it is, with any figures a FIGURES=1 landing committed beside it.
landed_already() { # RESULTS
  local tag=${1#results} r c
  tag=${tag%.json}
  [ -z "${FIGURES:-}" ] && [ -f "$dest/report$tag.md" ] || return 1
  for r in "$src"/cells/*/"$1"; do
    [ -f "$r" ] || continue
    c=${r%/*}
    cmp -s "$r" "$dest/cells/${c##*/}/$1" || return 1
  done
}
town2() { ls "$src"/cells/*/results-town2.json > /dev/null 2>&1; }
if [ "$results" = both ]; then # the test town, then town 2 over the cells that have it
  # Decided for both before the first copies the cells (and their town-2 results) in.
  if landed_already results.json && { ! town2 || landed_already results-town2.json; }; then
    echo "nothing new: the reports in $dest left as landed"
    exit
  fi
  export LANDING=1
  "$0" "$bin" "$src" "$dest" results.json
  if town2; then
    "$0" "$bin" "$src" "$dest" results-town2.json
  fi
  exit
fi
tag=${results#results}
tag=${tag%.json}
if [ -z "${LANDING:-}" ] && landed_already "$results"; then
  echo "nothing new: $dest/report$tag.md left as landed"
  exit
fi
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
