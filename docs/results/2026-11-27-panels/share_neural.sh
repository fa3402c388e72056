#!/usr/bin/env bash
# The controllers panel's NeuralAE cells in calibrated and blur x4 are the perturbation panel's
# paper-search cells: the same binary (target/panelbin/joca, 6b2a6e9), and `cell.toml` identical
# byte for byte (checked here, cell by cell), so the same computation. Copies each finished one
# into runs/ctrl-panel instead of running it again, with a note of where it came from.
cd /work/main
for sc in calibrated blur4; do
  for d in flir basler cmv2000-10mm mt9v032-6mm python500-7mm imx287-10mm; do
    src=runs/pert-panel/cells/paper-$sc-$d
    dst=runs/ctrl-panel/cells/neural-$sc-$d
    [ -f "$src/results.json" ] && [ -d "$dst" ] && [ ! -f "$dst/results.json" ] || continue
    if cmp -s "$src/cell.toml" "$dst/cell.toml"; then
      cp -a "$src/." "$dst/"
      echo "copied from $src (same binary, identical cell.toml: the same computation)" \
        > "$dst/copied-from.txt"
      echo "$(date -u +%FT%TZ) shared $src -> $dst"
    else
      echo "$(date -u +%FT%TZ) NOT shared $src: cell.toml differs"
    fi
  done
done
