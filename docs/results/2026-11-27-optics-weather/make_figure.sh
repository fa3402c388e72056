#!/usr/bin/env bash
# The issue-41 figure: one street (map 0, episode 0, day, IMX172 behind 8 mm, 800x600 input)
# through the ideal pinhole, f/16 and f/1.4 (focused at 5 m and at 1.5 m), in fog (visibility
# 300 m and 100 m) and in rain (25 mm/h at 5 ms and at 40 ms). The lens and fog frames are the
# 15th of an AverageAE sequence (converged exposure); the rain frames use fixed settings of equal
# exposure x gain. Needs Python with Pillow for the contact sheet (compose.py).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$here/../../.."
out="${1:-/tmp/joca-optics-figure}"
rm -rf "$out" && mkdir -p "$out"
common=(--map-seed 0 --episode 0 --illumination day --sensor IMX172 --focal-mm 8 --short-px 600 --long-max-px 800)
seq=(--frames 15 --start-s 2)
one=(--frames 1 --start-s 3.4)
j() { "$repo/joca" render "${common[@]}" "$@" > /dev/null; }
j "${seq[@]}" --out "$out/pinhole"
j "${seq[@]}" --f-number 16 --focus-m 5 --out "$out/f16"
j "${seq[@]}" --f-number 1.4 --focus-m 5 --out "$out/f1.4-5m"
j "${seq[@]}" --f-number 1.4 --focus-m 1.5 --out "$out/f1.4-1.5m"
j "${seq[@]}" --fog-visibility-m 300 --out "$out/fog300"
j "${seq[@]}" --fog-visibility-m 100 --out "$out/fog100"
j "${one[@]}" --rain-mm-h 25 --exposure-ms 5 --gain-db 28.06 --out "$out/rain-5ms"
j "${one[@]}" --rain-mm-h 25 --exposure-ms 40 --gain-db 10 --out "$out/rain-40ms"
python3 "$here/compose.py" "$out" "$here/optics-weather.jpg"
