#!/usr/bin/env bash
# The controllers panel's NeuralAE cells and the ablation panel's `joca` cells, in calibrated and
# blur x4, are the perturbation panel's cells of ours' search (VARIANT: `loss-linear`, every
# preset's search since session 36, by default; `paper`, the paper's search, until then): the
# same binary (target/panelbin/joca) and a `cell.toml` identical byte for byte (checked here,
# cell by cell), so the same computation. Copies each finished one into runs/ctrl-panel and
# runs/ablation-panel instead of running it again, with a note of where it came from. A panel
# directory not yet made is skipped. Likewise issue 41's clear-weather fog cells (runs/fog, ours
# and TaCOS + AverageAE in calibrated) are Table 1's calibrated cells of the same seed.
# Usage: share_cells.sh [VARIANT]
cd "$(dirname "${BASH_SOURCE[0]}")/../../.."
variant=${1:-loss-linear}
share() { # SRC DST: copies a finished SRC into an unfinished DST if their cell.toml are identical
  if [ -f "$2/copied-from.txt" ]; then # shared before SRC's later tests (eval_town.sh) were in
    for f in "$1"/results-town*.json; do
      [ -f "$f" ] && [ ! -f "$2/${f##*/}" ] || continue
      cp -a "$f" "$2/" && echo "$(date -u +%FT%TZ) shared $f -> $2"
    done
    return 0
  fi
  [ -f "$1/results.json" ] && [ -d "$2" ] && [ ! -f "$2/results.json" ] || return 0
  if cmp -s "$1/cell.toml" "$2/cell.toml"; then
    cp -a "$1/." "$2/"
    echo "copied from $1 (same binary, identical cell.toml: the same computation)" \
      > "$2/copied-from.txt"
    echo "$(date -u +%FT%TZ) shared $1 -> $2"
  else
    echo "$(date -u +%FT%TZ) NOT shared $1 -> $2: cell.toml differs"
  fi
}
for target in ctrl-panel:neural ablation-panel:joca; do
  dir=runs/${target%%:*}
  prefix=${target##*:}
  for sc in calibrated blur4; do
    for d in flir basler cmv2000-10mm mt9v032-6mm python500-7mm imx287-10mm; do
      share "runs/pert-panel/cells/$variant-$sc-$d" "$dir/cells/$prefix-$sc-$d"
    done
  done
done
for s in 0 1 2; do
  share "runs/table1-ours/cells/joca-calibrated-s$s" "runs/fog/cells/joca-clear-calibrated-s$s"
  share "runs/table1-tacos/cells/tacos-calibrated-s$s" "runs/fog/cells/tacos-clear-calibrated-s$s"
done
