#!/usr/bin/env bash
# The controllers panel's NeuralAE cells and the ablation panel's `joca` cells, in calibrated and
# blur x4, are the perturbation panel's cells of ours' search (VARIANT: `loss-linear`, every
# preset's search since session 36, by default; `paper`, the paper's search, until then): the
# same binary (target/panelbin/joca) and a `cell.toml` identical byte for byte (checked here,
# cell by cell), so the same computation. Copies each finished one into runs/ctrl-panel and
# runs/ablation-panel instead of running it again, with a note of where it came from. A panel
# directory not yet made is skipped. Usage: share_cells.sh [VARIANT]
cd "$(dirname "${BASH_SOURCE[0]}")/../../.."
variant=${1:-loss-linear}
for target in ctrl-panel:neural ablation-panel:joca; do
  dir=runs/${target%%:*}
  prefix=${target##*:}
  for sc in calibrated blur4; do
    for d in flir basler cmv2000-10mm mt9v032-6mm python500-7mm imx287-10mm; do
      src=runs/pert-panel/cells/$variant-$sc-$d
      dst=$dir/cells/$prefix-$sc-$d
      [ -f "$src/results.json" ] && [ -d "$dst" ] && [ ! -f "$dst/results.json" ] || continue
      if cmp -s "$src/cell.toml" "$dst/cell.toml"; then
        cp -a "$src/." "$dst/"
        echo "copied from $src (same binary, identical cell.toml: the same computation)" \
          > "$dst/copied-from.txt"
        echo "$(date -u +%FT%TZ) shared $src -> $dst"
      else
        echo "$(date -u +%FT%TZ) NOT shared $src -> $dst: cell.toml differs"
      fi
    done
  done
done
