#!/usr/bin/env bash
# Builds joca for a GPU node that has PyTorch but no Rust toolchain and no network (the node
# ../shared/notes/libtorch-cuda.md describes: torch 2.11.0+cu130), on this CPU machine: a scratch
# copy of the checkout with tch pinned to the release generated for that torch (0.24), linked
# against the CPU libraries of PyPI's torch 2.11.0 wheel. On the node the binary runs on that
# torch's own libraries (LD_LIBRARY_PATH, set by run.sh) and loads their CUDA part itself.
#
# Output: <repo>/gpu-check/joca (git-ignored); scripts/gpu-check/run.sh runs the check there.
# Usage: scripts/gpu-check/build.sh   (about 10 minutes on 2 cores; the wheel is cached)
set -euo pipefail

TORCH_VERSION=${JOCA_GPU_TORCH:-2.11.0}
TCH_VERSION=${JOCA_GPU_TCH:-0.24.0}
CUDA_TOOLKIT_VERSION=${JOCA_GPU_CUDA_TOOLKIT:-13.0.2}

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
scratch="${JOCA_GPU_SCRATCH:-${TMPDIR:-/tmp}/joca-gpu-build}"
cache="${JOCA_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/joca}/wheels"
python=${PYTHON:-python3}
mkdir -p "$cache" "$scratch"

if ! compgen -G "$cache/torch-$TORCH_VERSION-*.whl" >/dev/null; then
  echo "gpu-check: downloading torch==$TORCH_VERSION (once per machine) into $cache"
  "$python" -m pip download --quiet --no-deps --only-binary=:all: \
    --platform manylinux_2_28_x86_64 --python-version 3.12 --implementation cp \
    "torch==$TORCH_VERSION" -d "$cache"
fi
if ! compgen -G "$cache/nvidia_cuda_runtime-*.whl" >/dev/null; then
  "$python" -m pip download --quiet --only-binary=:all: \
    "cuda-toolkit[cudart,cupti]==$CUDA_TOOLKIT_VERSION" -d "$cache"
fi

echo "gpu-check: torch $TORCH_VERSION's CPU libraries and headers into $scratch/libtorch"
rm -rf "$scratch/libtorch"
"$python" - "$cache" "$scratch/libtorch" "$TORCH_VERSION" <<'PY'
import glob, os, shutil, sys, zipfile
cache, out, version = sys.argv[1:4]
wheel = sorted(glob.glob(os.path.join(cache, f"torch-{version}-*.whl")))[0]
cpu = {"libtorch_cpu.so", "libtorch.so", "libc10.so", "libgomp.so.1"}
with zipfile.ZipFile(wheel) as whl:
    for info in whl.infolist():
        name = info.filename
        if name.startswith("torch/include/") and not name.endswith("/"):
            target = os.path.join(out, "include", name[len("torch/include/"):])
        elif name.startswith("torch/lib/") and os.path.basename(name) in cpu:
            target = os.path.join(out, "lib", os.path.basename(name))
        else:
            continue
        os.makedirs(os.path.dirname(target), exist_ok=True)
        with whl.open(info) as src, open(target, "wb") as dst:
            shutil.copyfileobj(src, dst)
# libtorch_cpu.so names the CUDA runtime and CUPTI; the link needs them, the node has its own.
for pattern, wanted in (("nvidia_cuda_runtime-*.whl", "libcudart.so.13"),
                        ("nvidia_cuda_cupti-*.whl", "libcupti.so.13")):
    with zipfile.ZipFile(sorted(glob.glob(os.path.join(cache, pattern)))[-1]) as whl:
        member = next(n for n in whl.namelist() if n.endswith("/" + wanted))
        with whl.open(member) as src, open(os.path.join(out, "lib", wanted), "wb") as dst:
            shutil.copyfileobj(src, dst)
PY

echo "gpu-check: a scratch copy with tch $TCH_VERSION in $scratch/src"
mkdir -p "$scratch/src"
# The tracked and untracked sources as they are now (uncommitted changes included).
(cd "$repo" && git ls-files -co --exclude-standard -z | tar --null -T - -cf -) \
  | (cd "$scratch/src" && tar -xf -)
sed -i "s/^tch = \"=[0-9.]*\"/tch = \"=$TCH_VERSION\"/" "$scratch/src/Cargo.toml"
cd "$scratch/src"
cargo update --quiet -p tch --precise "$TCH_VERSION"
# RUSTFLAGS replaces .cargo/config.toml's run paths: on the node LD_LIBRARY_PATH finds torch.
LIBTORCH="$scratch/libtorch" RUSTFLAGS="-C link-arg=-Wl,-rpath,\$ORIGIN" \
  cargo build --release --quiet -p joca-cli
mkdir -p "$repo/gpu-check"
cp target/release/joca "$repo/gpu-check/joca"
echo "$TORCH_VERSION" >"$repo/gpu-check/TORCH_VERSION"
echo "gpu-check: built $repo/gpu-check/joca for torch $TORCH_VERSION ($(du -h "$repo/gpu-check/joca" | cut -f1))"
