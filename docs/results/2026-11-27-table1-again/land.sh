#!/usr/bin/env bash
# Lands Table 1 again's finished cells: each of its three experiment folders (runs/table1-baselines,
# runs/table1-tacos, runs/table1-ours) into DEST/{baselines,tacos,ours} with its report on both
# towns (the panels' land.sh), then the table from issue 39's grid cells and these
# (table1.py, later folders replacing same-named cells) into DEST/table1.md.
# Usage: land.sh [JOCA_BINARY] (default target/release/joca)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../../.."
bin=${1:-target/release/joca}
panels=docs/results/2026-11-27-panels
dest=docs/results/2026-11-27-table1-again
cells=(docs/results/2026-11-27-detector-input/standard/cells)
for part in baselines tacos ours; do
  src=runs/table1-$part
  if ls "$src"/cells/*/results.json > /dev/null 2>&1; then
    $panels/land.sh "$bin" "$src" "$dest/$part" both | grep "^landed\|^nothing new"
  fi
  [ -d "$dest/$part/cells" ] && cells+=("$dest/$part/cells")
done
python3 $dest/table1.py "${cells[@]}" > "$dest/table1.md"
