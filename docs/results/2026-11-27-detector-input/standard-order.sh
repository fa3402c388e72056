#!/usr/bin/env bash
# Runs the standard grid's cells in the order the must-shows need them (the noise loss of the
# fixed cameras first, then ours and TaCOS seed by seed), then the experiment for its report.
cd "$(dirname "${BASH_SOURCE[0]}")/../../.."
bin=target/gridbin/joca
dir=runs/std-input
while pgrep -f "gridbin/joca cell" >/dev/null; do sleep 15; done
order="flir-calibrated-s0 flir-calibrated-s1 flir-calibrated-s2 basler-calibrated-s0 basler-calibrated-s1 basler-calibrated-s2
flir-noise20-s0 basler-noise20-s0 flir-noise20-s1 basler-noise20-s1 flir-noise20-s2 basler-noise20-s2"
for s in 0 1 2; do order="$order tacos-calibrated-s$s joca-calibrated-s$s tacos-noise20-s$s joca-noise20-s$s"; done
for id in $order; do
  cell="$dir/cells/$id"
  [ -f "$cell/results.json" ] && continue
  echo "$(date -u +%FT%TZ) start $id"
  "$bin" cell "$cell" >> "$cell/cell.log" 2>&1 && echo "$(date -u +%FT%TZ) done  $id" || echo "$(date -u +%FT%TZ) FAILED $id"
done
"$bin" experiment docs/results/2026-11-27-detector-input/quick-grid.toml --preset standard --seeds 3 --out "$dir"
