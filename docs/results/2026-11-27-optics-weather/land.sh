#!/usr/bin/env bash
# Lands issue 41's finished runs: runs/aperture and runs/fog into DEST/{aperture,fog} with their
# reports on both towns (the panels' land.sh), then each one's tables (optics.py) into
# DEST/aperture.md and DEST/fog.md. Usage: land.sh [JOCA_BINARY] (default target/release/joca)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../../.."
bin=${1:-target/release/joca}
panels=docs/results/2026-11-27-panels
dest=docs/results/2026-11-27-optics-weather
for part in aperture fog; do
  src=runs/$part
  ls "$src"/cells/*/results.json > /dev/null 2>&1 || continue
  $panels/land.sh "$bin" "$src" "$dest/$part" both | grep "^landed\|^nothing new"
  python3 $dest/optics.py "$part" "$dest/$part/cells" > "$dest/$part.md"
done
