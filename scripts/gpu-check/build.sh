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
mkdir -p "$scratch"

echo "gpu-check: torch $TORCH_VERSION's CPU libraries and headers into $scratch/libtorch"
env -u LIBTORCH JOCA_TORCH_VERSION="$TORCH_VERSION" JOCA_CUDA_TOOLKIT_VERSION="$CUDA_TOOLKIT_VERSION" \
  JOCA_LIBTORCH_DIR="$scratch/libtorch" "$repo/scripts/bootstrap-libtorch.sh"

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
