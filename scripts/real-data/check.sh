#!/usr/bin/env bash
# Real frames through joca, from data the package registries ship (nothing of it is committed):
# - scikit-image's wheel (BSD-3): Middlebury's motorcycle stereo pair with dense ground-truth
#   disparity. `joca flow --gt-disparity` must stay below a bound per DIS preset (a guard against
#   regressions, about 0.4 px above what joca measures; docs/results/ has the
#   measured values beside OpenCV's).
# - labelme's sdist (GPL-3, read, not shipped): five consecutive real street frames with polygon
#   labels. `joca import labelme` must turn them into the folder format with their 15 objects;
#   DIS runs on the first two frames.
# Downloads go to $JOCA_REAL_DATA (default ~/.cache/joca-real-data) with pip; when they cannot
# be fetched (offline), the check says so and passes. Run by .ci/run after the tests.
# Usage: scripts/real-data/check.sh [JOCA_BINARY]
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
joca="${1:-$repo/joca}"
cache="${JOCA_REAL_DATA:-$HOME/.cache/joca-real-data}"
declare -A END_POINT_ERROR_PX=([ultrafast]=3.9 [fast]=3.6 [medium]=3.05)
mkdir -p "$cache"
work="$(mktemp -d /tmp/joca-real-data.XXXXXX)"
trap 'rm -rf "$work"' EXIT

skip() {
  echo "real-data: skipped — $1 (offline, or the registry is unreachable); nothing was checked"
  exit 0
}

# A Python with numpy for the .npz → .npy conversion, in the cache.
if [ ! -x "$cache/venv/bin/python" ]; then
  python3 -m venv "$cache/venv" >/dev/null 2>&1 || skip "cannot create a Python virtual environment"
fi
"$cache/venv/bin/python" -c "import numpy" 2>/dev/null ||
  timeout 300 "$cache/venv/bin/pip" install --quiet numpy >/dev/null 2>&1 || skip "cannot install numpy"
ls "$cache"/scikit_image-0.26.0-*.whl >/dev/null 2>&1 ||
  timeout 300 "$cache/venv/bin/pip" download --quiet --no-deps scikit-image==0.26.0 -d "$cache" \
    >/dev/null 2>&1 || skip "cannot download scikit-image 0.26.0"
[ -f "$cache/labelme-5.8.3.tar.gz" ] ||
  timeout 300 "$cache/venv/bin/pip" download --quiet --no-deps --no-binary :all: labelme==5.8.3 \
    -d "$cache" >/dev/null 2>&1 || skip "cannot download labelme 5.8.3"

# The motorcycle pair and its disparity as .npy.
"$cache/venv/bin/python" - "$cache" "$work" <<'EOF'
import glob, io, sys, zipfile
import numpy as np
cache, work = sys.argv[1], sys.argv[2]
wheel = zipfile.ZipFile(sorted(glob.glob(f"{cache}/scikit_image-0.26.0-*.whl"))[0])
for name in ("motorcycle_left.png", "motorcycle_right.png"):
    open(f"{work}/{name}", "wb").write(wheel.read(f"skimage/data/{name}"))
disp = np.load(io.BytesIO(wheel.read("skimage/data/motorcycle_disp.npz")))
np.save(f"{work}/motorcycle_disp.npy", disp[disp.files[0]].astype(np.float32))
EOF
for preset in ultrafast fast medium; do
  out="$("$joca" flow "$work/motorcycle_left.png" "$work/motorcycle_right.png" \
    --out "$work/flow-$preset.png" --preset "$preset" --gt-disparity "$work/motorcycle_disp.npy")"
  epe="$(sed -n 's/.*end-point error \([0-9.]*\) px.*/\1/p' <<<"$out")"
  echo "real-data: motorcycle pair, DIS $preset: end-point error $epe px"
  bound="${END_POINT_ERROR_PX[$preset]}"
  awk -v e="$epe" -v m="$bound" 'BEGIN { exit !(e != "" && e < m) }' || {
    echo "real-data: FAILED — $preset end-point error '$epe' px is not below $bound px"
    echo "$out"
    exit 1
  }
done

# The labelme street frames into the folder format.
tar -xzf "$cache/labelme-5.8.3.tar.gz" -C "$work" labelme-5.8.3/examples/video_annotation/data_annotated
out="$("$joca" import labelme "$work/labelme-5.8.3/examples/video_annotation/data_annotated" \
  --frame-interval-ms 33.3 --class track=vehicle --out "$work/street")"
echo "real-data: $out"
grep -q "wrote 5 frames with 15 objects" <<<"$out" || { echo "real-data: FAILED — labelme import"; exit 1; }
"$joca" flow "$work/street/frames/data_annotated/00000100.jpg" \
  "$work/street/frames/data_annotated/00000101.jpg" --out "$work/street-flow.png" --preset fast |
  sed 's/^/real-data: street frames 100 → 101: /'
echo "real-data: ok"
