#!/usr/bin/env bash
# Tests each named cell again with the detector weights it started from in place of its trained
# detector (`joca eval --detector start`, on the test town and on town TOWN), on the design and
# with the controller it trained: with the frozen-detector cell of the same design this splits
# "frozen detector − ours" into the detector's part (ours' controller, either detector) and the
# controller's part (the starting detector, either controller). Skips what is done.
# Usage: detector_swap.sh JOCA_BINARY TOWN CELL_DIR...
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../../.."
bin=$1 town=$2
shift 2
for d in "$@"; do
  [ -f "$d/results.json" ] && [ -d "$d/checkpoint" ] || continue
  for t in 0 "$town"; do
    name=results-detector-start.json
    [ "$t" = 0 ] || name=results-detector-start-town$t.json
    [ -f "$d/$name" ] && continue
    echo "$(date -u +%FT%TZ) swap  $d town $t"
    "$bin" eval "$d" --detector start --town "$t" > "$d/eval-detector-start-town$t.log" 2>&1 \
      && head -1 "$d/eval-detector-start-town$t.log" \
      || echo "FAILED $d: $(tail -1 "$d/eval-detector-start-town$t.log")"
  done
done
