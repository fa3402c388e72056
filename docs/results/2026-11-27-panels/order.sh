#!/usr/bin/env bash
# Issue 40's perturbation panel at `standard`, two one-thread cells at a time, in paired order:
# per scenario and design the paper's search beside the task-loss/relative one (the comparison
# that decides the default) so each design's pair lands together; the linear-step variant last.
# Skips finished cells, resumes partial ones, and counts cells already running (also ones started
# by an earlier `joca experiment`). Then writes the experiment's report.
cd /work/main
# As `joca experiment --jobs 2` does: libtorch's OpenMP threads wait without spinning.
export OMP_WAIT_POLICY=PASSIVE
bin=target/panelbin/joca
dir=runs/pert-panel
designs="flir basler cmv2000-10mm mt9v032-6mm python500-7mm imx287-10mm"
order=""
for sc in calibrated blur4; do
  for d in $designs; do order="$order paper-$sc-$d loss-relative-$sc-$d"; done
done
for sc in calibrated blur4; do
  for d in $designs; do order="$order loss-linear-$sc-$d"; done
done
for id in $order; do
  cell="$dir/cells/$id"
  [ -f "$cell/results.json" ] && continue
  pgrep -f "joca cell $cell\$" >/dev/null && continue
  while [ "$(pgrep -fc 'panelbin/joca cell')" -ge 2 ]; do sleep 20; done
  echo "$(date -u +%FT%TZ) start $id"
  ( "$bin" cell "$cell" >> "$cell/cell.log" 2>&1 \
      && echo "$(date -u +%FT%TZ) done  $id" || echo "$(date -u +%FT%TZ) FAILED $id" ) &
  sleep 5
done
while pgrep -f "panelbin/joca cell" >/dev/null; do sleep 30; done
"$bin" experiment perturbation-panel --preset standard --seeds 1 --jobs 2 \
  --config docs/results/2026-11-27-panels/threads1.toml --out "$dir"
