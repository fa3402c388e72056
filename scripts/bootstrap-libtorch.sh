#!/usr/bin/env bash
# Prepares libtorch 2.13.0 for the `tch` crate in `<repo>/.libtorch`: its CPU libraries (the
# default), or with JOCA_LIBTORCH=cuda its CUDA libraries too, for `--device cuda`.
#
# Why this exists: tch 0.26 builds only against libtorch 2.13.0, and the one place our machines can
# get that is PyPI's `torch==2.13.0` wheel (a CUDA build). Its CPU libraries work without a GPU when
# `libtorch_cuda.so` is left out, but `libtorch_cpu.so` still needs `libcudart.so.13` and
# `libcupti.so.13`, which come from `cuda-toolkit[cudart,cupti]==13.0.3`. We extract only what a
# CPU build links against; nothing is installed into any Python environment.
#
# JOCA_LIBTORCH=cuda (about 4 GB more, once per machine) extracts every library of the torch wheel
# and of the NVIDIA wheels its metadata names for Linux (cuBLAS, cuDNN, NCCL, …) into the same
# folder: `libtorch_cuda.so` finds them there through its `$ORIGIN` run path, and joca loads it at
# run time when a GPU is asked for (crates/joca-nn/src/device/cuda.rs), so the binary is the same
# as a CPU build's. It needs an NVIDIA driver for CUDA 13 (580 or newer) to use a GPU.
#
# Wheels are cached in ${JOCA_CACHE:-$XDG_CACHE_HOME/joca or ~/.cache/joca}/wheels, so a second
# checkout on the same machine extracts in seconds without downloading again.
#
# Users who already have libtorch 2.13.0 set LIBTORCH and this script does nothing.
#
# scripts/gpu-check/build.sh prepares another torch's CPU part into another folder with
# JOCA_TORCH_VERSION, JOCA_CUDA_TOOLKIT_VERSION (the cuda-toolkit pin of that torch's wheel) and
# JOCA_LIBTORCH_DIR; joca's own build needs the defaults.
set -euo pipefail

TORCH_VERSION=${JOCA_TORCH_VERSION:-2.13.0}
CUDA_TOOLKIT_VERSION=${JOCA_CUDA_TOOLKIT_VERSION:-13.0.3}
flavour=${JOCA_LIBTORCH:-cpu}
case "$flavour" in
  cpu) stamp="$TORCH_VERSION" ;;
  cuda) stamp="$TORCH_VERSION+cuda" ;;
  *)
    echo "bootstrap-libtorch: JOCA_LIBTORCH=$flavour: allowed values are cpu (the default) and cuda" >&2
    exit 1
    ;;
esac

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
dest="${JOCA_LIBTORCH_DIR:-$repo/.libtorch}"

if [[ -n "${LIBTORCH:-}" && "${LIBTORCH}" != "$dest" ]]; then
  echo "bootstrap-libtorch: LIBTORCH=$LIBTORCH is set; using it and skipping the bootstrap."
  exit 0
fi
if [[ -f "$dest/VERSION" ]]; then
  have="$(cat "$dest/VERSION")"
  # A CUDA libtorch serves CPU runs too: only a CPU one is replaced, when CUDA is asked for.
  if [[ "$have" == "$stamp" || ("$flavour" == cpu && "$have" == "$TORCH_VERSION+cuda") ]]; then
    exit 0
  fi
fi

cache="${JOCA_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/joca}/wheels"
mkdir -p "$cache"
python=${PYTHON:-python3}
if ! command -v "$python" >/dev/null; then
  echo "bootstrap-libtorch: needs python3 with pip to fetch the libtorch wheel from PyPI" >&2
  exit 1
fi

if ! compgen -G "$cache/torch-$TORCH_VERSION-*.whl" >/dev/null; then
  echo "bootstrap-libtorch: downloading torch==$TORCH_VERSION (~530 MB, once per machine) into $cache"
  "$python" -m pip download --quiet --no-deps --only-binary=:all: \
    --platform manylinux_2_28_x86_64 --python-version 3.11 --implementation cp \
    "torch==$TORCH_VERSION" -d "$cache"
fi
if ! compgen -G "$cache/nvidia_cuda_runtime-*.whl" >/dev/null || ! compgen -G "$cache/nvidia_cuda_cupti-*.whl" >/dev/null; then
  echo "bootstrap-libtorch: downloading cuda-toolkit[cudart,cupti]==$CUDA_TOOLKIT_VERSION (~13 MB)"
  # NVIDIA tags these wheels with different manylinux levels (cudart manylinux_2_17, cupti
  # manylinux_2_25), and pip before 24 does not count an older manylinux as compatible with an
  # explicit --platform, so every level from 2_17 (= manylinux2014) up to torch's 2_28 is listed.
  platforms=()
  for glibc_minor in $(seq 17 28); do platforms+=(--platform "manylinux_2_${glibc_minor}_x86_64"); done
  "$python" -m pip download --quiet --only-binary=:all: "${platforms[@]}" \
    --python-version 3.11 --implementation cp \
    "cuda-toolkit[cudart,cupti]==$CUDA_TOOLKIT_VERSION" -d "$cache"
fi

if [[ "$flavour" == cuda ]]; then
  # The NVIDIA wheels the torch wheel names for Linux, at its pinned versions.
  mapfile -t cuda_reqs < <("$python" - "$cache" "$TORCH_VERSION" <<'PY'
import glob, os, re, sys, zipfile
cache, version = sys.argv[1], sys.argv[2]
whl = sorted(glob.glob(os.path.join(cache, f"torch-{version}-*.whl")))[0]
with zipfile.ZipFile(whl) as z:
    meta = z.read(f"torch-{version}.dist-info/METADATA").decode()
for line in meta.splitlines():
    m = re.match(r"Requires-Dist: ((?:nvidia-|cuda-toolkit)[^;]*);\s*(.*)", line)
    if m and 'platform_system == "Linux"' in m.group(2) and "extra" not in m.group(2):
        print(m.group(1).replace(" ", ""))
PY
  )
  if ! compgen -G "$cache/nvidia_cublas-*.whl" >/dev/null || ! compgen -G "$cache/nvidia_cudnn_cu13-*.whl" >/dev/null; then
    echo "bootstrap-libtorch: downloading torch's CUDA libraries (~3 GB, once per machine): ${cuda_reqs[*]}"
    # The host's own tags (Linux x86-64): NVIDIA tags these wheels with many manylinux levels.
    "$python" -m pip download --quiet --only-binary=:all: "${cuda_reqs[@]}" -d "$cache"
  fi
fi

tmp="$dest.partial"
rm -rf "$tmp"
mkdir -p "$tmp/lib" "$tmp/include"
echo "bootstrap-libtorch: extracting $flavour libraries and headers into $dest"
"$python" - "$cache" "$tmp" "$TORCH_VERSION" "$flavour" <<'PY'
import glob, os, shutil, sys, zipfile

cache, out, version, flavour = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
torch_whl = sorted(glob.glob(os.path.join(cache, f"torch-{version}-*.whl")))[0]
# The CPU build needs exactly these shared objects; libtorch_cuda.so is left out on purpose so
# that torch-sys builds for CPU and the binary runs on machines without a GPU.
cpu_libs = {"libtorch_cpu.so", "libtorch.so", "libc10.so", "libgomp.so.1"}
with zipfile.ZipFile(torch_whl) as whl:
    for info in whl.infolist():
        name = info.filename
        if name.startswith("torch/include/") and not name.endswith("/"):
            target = os.path.join(out, "include", name[len("torch/include/"):])
        elif name.startswith("torch/lib/") and (
            os.path.basename(name) in cpu_libs
            or (flavour == "cuda" and ".so" in os.path.basename(name) and name.count("/") == 2)
        ):
            target = os.path.join(out, "lib", os.path.basename(name))
        else:
            continue
        os.makedirs(os.path.dirname(target), exist_ok=True)
        with whl.open(info) as src, open(target, "wb") as dst:
            shutil.copyfileobj(src, dst)
if flavour == "cuda":
    # Every shared library of the NVIDIA wheels, flat beside libtorch_cuda.so ($ORIGIN).
    for whl_path in sorted(glob.glob(os.path.join(cache, "nvidia_*.whl"))):
        with zipfile.ZipFile(whl_path) as whl:
            for info in whl.infolist():
                base = os.path.basename(info.filename)
                if "/lib/" in info.filename and ".so" in base and not info.filename.endswith("/"):
                    with whl.open(info) as src, open(os.path.join(out, "lib", base), "wb") as dst:
                        shutil.copyfileobj(src, dst)
for pattern, wanted in (("nvidia_cuda_runtime-*.whl", "libcudart.so.13"),
                        ("nvidia_cuda_cupti-*.whl", "libcupti.so.13")):
    with zipfile.ZipFile(sorted(glob.glob(os.path.join(cache, pattern)))[0]) as whl:
        member = next(n for n in whl.namelist() if n.endswith("/" + wanted))
        with whl.open(member) as src, open(os.path.join(out, "lib", wanted), "wb") as dst:
            shutil.copyfileobj(src, dst)
PY
echo "$stamp" >"$tmp/VERSION"
rm -rf "$dest"
mv "$tmp" "$dest"
echo "bootstrap-libtorch: ready ($(du -sh "$dest" | cut -f1))"
