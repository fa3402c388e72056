#!/usr/bin/env bash
# Starts issue 40's panels again on a fresh machine (sessions may start without runs/): builds
# the panel binary if missing, rebuilds each experiment folder from its committed compact cells
# (restore.sh), prepares the missing cells (`joca experiment --prepare`, which also checks every
# restored cell.toml against the grid), shares ours' cells (share_cells.sh) and runs the cells
# listed below, two at a time, in order (run_cells.sh). A cell that has not finished when the
# machine goes is lost (its checkpoint stays on that machine): land finished cells as they come
# (land.sh) and commit them.
# Usage: resume.sh [CELL ...]: the named cells first (a scenario's missing seeds, say), then the
# priority list below.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../../.."
here=docs/results/2026-11-27-panels
bin=${PANEL_BIN:-target/panelbin/joca}
prep=${PREP_BIN:-target/release/joca}
if [ ! -x "$bin" ] || [ ! -x "$prep" ]; then
  scripts/bootstrap-libtorch.sh
  cargo build --release -p joca-cli
  mkdir -p "$(dirname "$bin")"
  [ -x "$bin" ] || cp target/release/joca "$bin"
fi
# Each finished cell is then re-tested on town 2 of the test family (run_cells.sh) by a joca with
# `eval --town` (9880527 on): the panel binary predates it.
export EVAL_BIN=${EVAL_BIN:-target/evalbin/joca}
if [ ! -x "$EVAL_BIN" ]; then
  cargo build --release -p joca-cli
  mkdir -p "$(dirname "$EVAL_BIN")"
  cp target/release/joca "$EVAL_BIN"
fi
# Every cell on libtorch's AVX2 kernels, hence fp32 scoring, whatever the CPU: the controllers
# panel and ours' cells ran on AVX2-only machines, and cells of one panel are paired across
# sessions whose machine type changes (on AVX-512 BF16 the default scores in bf16, other kernels).
export JOCA_CPU_KERNELS=${JOCA_CPU_KERNELS:-avx2}
opts=(--preset standard --config "$here/threads1.toml")
# Each experiment folder rebuilt from its committed compact cells, then prepared (which checks
# every restored cell.toml against the grid) by a binary of today's presets (PREP_BIN): the
# panel binary predates them.
runs_dirs=()
restore() { # COMPACT_DIR RUN_DIR EXPERIMENT SEEDS
  runs_dirs+=("$2")
  [ -d "$1/cells" ] && $here/restore.sh "$1/cells" "$2"
  "$prep" experiment "$3" "${opts[@]}" --seeds "$4" --out "$2" --prepare | tail -1
}
t1=docs/results/2026-11-27-table1-again
ow=docs/results/2026-11-27-optics-weather
restore $here/perturbation runs/pert-panel perturbation-panel 1
restore $here/controllers runs/ctrl-panel controllers 1
restore $here/ablation runs/ablation-panel ablation-panel 1
restore $t1/baselines runs/table1-baselines $t1/table1-baselines.toml 3
restore $t1/ours runs/table1-ours $t1/table1-ours.toml 3
restore $t1/tacos runs/table1-tacos $t1/table1-tacos.toml 3
restore $ow/aperture runs/aperture aperture 3
restore $ow/fog runs/fog fog 3
restore docs/results/2026-12-01-field-of-view/panel runs/fov-panel \
  docs/results/2026-12-01-field-of-view/fov-panel.toml 1
restore docs/results/2026-12-01-field-of-view/input runs/fov-input \
  docs/results/2026-12-01-field-of-view/fov-input.toml 1
# Ours' cells in calibrated and blur x4 are the perturbation panel's loss-linear cells; the fog
# experiment's clear-weather cells are Table 1's calibrated ones (run_cells.sh shares again
# before each cell, so those taken later are copied, not run).
$here/share_cells.sh loss-linear
c=runs/ctrl-panel/cells
a=runs/ablation-panel/cells
designs="flir basler cmv2000-10mm mt9v032-6mm python500-7mm imx287-10mm"
cells=("$@")
# The controllers panel, each design's AverageAE cell beside its NeuralAE one where both run;
# then the ablation panel, each design's three ablations together.
for sc in calibrated blur4 noise20; do
  for d in $designs; do cells+=("$c/average-$sc-$d" "$c/neural-$sc-$d"); done
done
for sc in calibrated blur4; do
  for d in $designs; do
    for v in no-ga-loss fixed-perturbation frozen-detector; do cells+=("$a/$v-$sc-$d"); done
  done
done
# The field-of-view checks (lens against sensor behind the fixed cameras' gap; twice the input),
# then Table 1.
for c in runs/fov-panel/cells/*/ runs/fov-input/cells/*/; do cells+=("${c%/}"); done
# Table 1 again (baselines and ours, seed by seed: issue 40 first, as its three seeds
# resolve it), then issue 41's fog runs (six cells to run, the clear-weather ones being shared),
# seed by seed, so one of its results completes first, then its aperture runs, seed by seed:
# the aperture gene against f/16 first (the issue's must-show), the per-frame iris (an option
# of the issue) after them.
for s in 0 1 2; do
  for sc in noise10 blur2 blur4; do
    for v in flir basler tacos; do cells+=("runs/table1-baselines/cells/$v-$sc-s$s"); done
  done
  for sc in calibrated noise20; do cells+=("runs/table1-tacos/cells/tacos-$sc-s$s"); done
  for sc in calibrated noise10 noise20 blur2 blur4; do
    cells+=("runs/table1-ours/cells/joca-$sc-s$s")
  done
done
for s in 0 1 2; do
  for v in tacos-clear joca-clear tacos-fog300 joca-fog300; do
    cells+=("runs/fog/cells/$v-calibrated-s$s")
  done
done
for vs in "f16 aperture" iris; do
  for s in 0 1 2; do
    for sc in calibrated noise20; do
      for v in $vs; do cells+=("runs/aperture/cells/$v-$sc-s$s"); done
    done
  done
done
# Cells finished before run_cells.sh re-tested them (their checkpoints still here), in the
# background beside the queue.
# (Not the perturbation panel: its only cells with checkpoints are the loss-linear ones, and
# their byte-identical copies in the controllers and ablation panels are re-tested there.)
for r in "${runs_dirs[@]}"; do
  [ "$r" = runs/pert-panel ] && continue
  [ -d "$r/cells" ] && $here/eval_town.sh "$EVAL_BIN" "$r" 2 >> runs/eval-town2.log 2>&1
done &
exec $here/run_cells.sh "$bin" "${cells[@]}"
