#!/usr/bin/env bash
# Issue 40's perturbation panel at `standard`, two one-thread cells at a time, in paired order:
# per scenario and design the paper's search beside the task-loss/relative one (the comparison
# that decides the default) so each design's pair lands together; the linear-step variant last.
# run_cells.sh skips finished cells, resumes partial ones, and counts cells already running (also
# ones started by an earlier `joca experiment`). Then writes the experiment's report.
cd "$(dirname "${BASH_SOURCE[0]}")/../../.."
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
cells=()
for id in $order; do cells+=("$dir/cells/$id"); done
docs/results/2026-11-27-panels/run_cells.sh "$bin" "${cells[@]}"
# Cells an earlier process started are not run_cells.sh's children: wait for them too.
while pgrep -f "panelbin/joca cell" >/dev/null; do sleep 30; done
"$bin" experiment perturbation-panel --preset standard --seeds 1 --jobs 2 \
  --config docs/results/2026-11-27-panels/threads1.toml --out "$dir"
