#!/usr/bin/env bash
# Runs the named cells (folders holding a cell.toml, prepared by `joca experiment` or copied),
# in the given order, at most two at a time, each `joca cell DIR` with its log in DIR/cell.log.
# Skips finished cells, resumes partial ones, and counts cells already running (also ones an
# earlier `joca experiment` started). With EVAL_BIN (a joca with `eval --town`), each cell it
# finishes is then tested again on town 2 of the test family (results-town2.json; see
# eval_town.sh), while its checkpoint is still on this machine. Before each cell, share_cells.sh
# copies in any cell that another panel's finished cell already computed (identical cell.toml).
# Usage: [EVAL_BIN=JOCA] run_cells.sh JOCA_BINARY CELL_DIR...
cd "$(dirname "${BASH_SOURCE[0]}")/../../.."
export OMP_WAIT_POLICY=PASSIVE
bin=${1:?joca binary}
shift
for cell in "$@"; do
  docs/results/2026-11-27-panels/share_cells.sh
  [ -f "$cell/results.json" ] && continue
  pgrep -f "joca cell $cell\$" >/dev/null && continue
  # Only cells under runs/ count: a test's `joca cell /tmp/...` must not take a slot.
  while [ "$(pgrep -fc 'joca cell runs/')" -ge 2 ]; do sleep 20; done
  echo "$(date -u +%FT%TZ) start $cell"
  ( "$bin" cell "$cell" >> "$cell/cell.log" 2>&1 \
      && echo "$(date -u +%FT%TZ) done  $cell" || { echo "$(date -u +%FT%TZ) FAILED $cell"; exit; }
    [ -z "${EVAL_BIN:-}" ] \
      || docs/results/2026-11-27-panels/eval_town.sh "$EVAL_BIN" "${cell%/cells/*}" 2 "${cell##*/}"
  ) &
  sleep 5
done
wait
