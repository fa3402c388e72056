#!/usr/bin/env bash
# Starts issue 40's panels again on a fresh machine (sessions may start without runs/): builds
# the panel binary if missing, rebuilds each experiment folder from its committed compact cells
# (restore.sh), prepares the missing cells (`joca experiment --prepare`, which also checks every
# restored cell.toml against the grid) and runs the cells listed below, two at a time, in order
# (run_cells.sh). A cell that has not finished when the machine goes is lost (its checkpoint
# stays on that machine): land finished cells as they come (land.sh) and commit them.
# Usage: resume.sh [CELL ...] (default: the priority list below).
set -euo pipefail
cd /work/main
here=docs/results/2026-11-27-panels
bin=${PANEL_BIN:-target/panelbin/joca}
if [ ! -x "$bin" ]; then
  scripts/bootstrap-libtorch.sh
  cargo build --release -p joca-cli
  mkdir -p target/panelbin
  cp target/release/joca "$bin"
fi
opts=(--preset standard --seeds 1 --config "$here/threads1.toml")
$here/restore.sh "$here/perturbation/cells" runs/pert-panel
"$bin" experiment perturbation-panel "${opts[@]}" --out runs/pert-panel --prepare | tail -1
if [ -d "$here/perturbation-mechanism/cells" ]; then
  $here/restore.sh "$here/perturbation-mechanism/cells" runs/pert-mechanism
fi
"$bin" experiment "$here/perturbation-mechanism.toml" "${opts[@]}" --out runs/pert-mechanism \
  --prepare | tail -1
p=runs/pert-panel/cells
m=runs/pert-mechanism/cells
designs="flir basler cmv2000-10mm mt9v032-6mm python500-7mm imx287-10mm"
if [ $# -gt 0 ]; then
  cells=("$@")
else
  # The linear-step variant (calibrated, then blur x4), then the mechanism follow-up in pairs.
  cells=()
  for d in $designs; do cells+=("$p/loss-linear-calibrated-$d"); done
  for d in $designs; do cells+=("$p/loss-linear-blur4-$d"); done
  for d in $designs; do cells+=("$m/ap50-relative-calibrated-$d" "$m/ap50-no-tie-break-calibrated-$d"); done
fi
exec $here/run_cells.sh "$bin" "${cells[@]}"
