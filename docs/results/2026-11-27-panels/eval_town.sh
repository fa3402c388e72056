#!/usr/bin/env bash
# Tests every finished cell of a panel again on a fresh town of the test family (`joca eval
# --town K`: the same trained detector and controller on the same design, other scenes of the
# same kind), one cell after another, skipping cells that already have results-town<K>.json.
# A paired difference that holds on the cells' own test town and on town K does not rest on one
# sample of test scenes. Land with `land.sh BIN RUN_DIR DEST_DIR results-town<K>.json`.
# Usage: eval_town.sh JOCA_BINARY RUN_DIR TOWN [CELL_NAME ...] (default: every cell)
set -euo pipefail
bin=$1 src=$2 town=$3
shift 3
if [ $# -gt 0 ]; then names=("$@"); else names=(); for d in "$src"/cells/*/; do names+=("$(basename "$d")"); done; fi
for id in "${names[@]}"; do
  d=$src/cells/$id
  [ -f "$d/results.json" ] && [ -d "$d/checkpoint" ] || continue
  [ -f "$d/results-town$town.json" ] && continue
  echo "$(date -u +%FT%TZ) eval  $id town $town"
  # A cell another eval holds (run_cells.sh's, just finished) is refused by its lock: go on.
  if "$bin" eval "$d" --town "$town" > "$d/eval-town$town.log" 2>&1; then
    head -1 "$d/eval-town$town.log"
  else
    echo "FAILED $id: $(tail -1 "$d/eval-town$town.log")"
  fi
done
echo "$(date -u +%FT%TZ) done  town $town in $src"
