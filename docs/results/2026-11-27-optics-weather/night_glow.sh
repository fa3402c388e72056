#!/usr/bin/env bash
# Fog's glow at night: one street (map 0, episode 0, night, IMX172 behind 8 mm, 800x600 input) in
# clear air and in fog of 300 m and 100 m visibility, at one fixed exposure and gain (so the
# frames differ only by the air). Needs Python with Pillow (night_compose.py).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$here/../../.."
out="${1:-/tmp/joca-night-glow}"
rm -rf "$out" && mkdir -p "$out"
common=(--map-seed 0 --episode 0 --illumination night --sensor IMX172 --focal-mm 8
  --short-px 600 --long-max-px 800 --frames 1 --start-s 3.4 --exposure-ms 50 --gain-db 30)
j() { "$repo/joca" render "${common[@]}" "$@" > /dev/null; }
j --out "$out/clear"
j --fog-visibility-m 300 --out "$out/fog300"
j --fog-visibility-m 100 --out "$out/fog100"
python3 "$here/night_compose.py" "$out" "$here/night-glow.jpg"
