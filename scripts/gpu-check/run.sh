#!/usr/bin/env bash
# The GPU check, run on a GPU node from the repository's root with gpu-check/joca built by
# scripts/gpu-check/build.sh on a CPU machine (the node needs PyTorch of the version in
# gpu-check/TORCH_VERSION with its CUDA libraries, no Rust and no network). It writes, into
# ${OUT:-gpu-check/out} (eight files at most):
#   node.txt          the GPU, driver, torch and CPU as the node reports them
#   bench-detector.txt `joca bench detector` on cuda, then on cpu (same node, same run of this script)
#   bench-step.txt    `joca bench step` (quick preset) on cuda, then on cpu
#   quick.txt         `joca run --preset quick --device cuda`: wall time and result table
#   quick-results.json its results.json (the GPU named in `device`)
#   standard.txt      one generation of a `standard` cell on cuda: wall time per candidate
#   repeat.txt        the quick run's test scored twice on cuda (`joca eval`): equal or not
# Each part has its own time limit, so one that hangs leaves the others' output.
set -uo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$repo"
out=${OUT:-gpu-check/out}
mkdir -p "$out"
work=$(mktemp -d)
joca=gpu-check/joca
torch_lib=$(python3 -c 'import os, torch; print(os.path.join(os.path.dirname(torch.__file__), "lib"))')
export LD_LIBRARY_PATH="$torch_lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
threads=$(nproc)
[[ $threads -gt 16 ]] && threads=16

{
  date -u
  nvidia-smi --query-gpu=name,memory.total,driver_version,compute_cap --format=csv || true
  python3 -c 'import torch; print("torch", torch.__version__, "cuda", torch.version.cuda)'
  echo "built for torch $(cat gpu-check/TORCH_VERSION 2>/dev/null)"
  grep -m1 'model name' /proc/cpuinfo
  echo "cores $(nproc)"
} >"$out/node.txt" 2>&1

timed() { # timed LIMIT_S FILE CMD…: runs CMD, appends its output and wall time to FILE
  local limit=$1 file=$2
  shift 2
  local t0=$SECONDS
  echo "\$ $*" >>"$file"
  timeout "$limit" "$@" >>"$file" 2>&1
  echo "exit $? after $((SECONDS - t0)) s" >>"$file"
}

timed 120 "$out/bench-detector.txt" $joca bench detector --device cuda --threads "$threads" --repeats 20
timed 120 "$out/bench-detector.txt" $joca bench detector --device cpu --threads "$threads" --repeats 5
timed 120 "$out/bench-step.txt" $joca bench step --device cuda --repeats 10
timed 150 "$out/bench-step.txt" $joca bench step --device cpu --repeats 5
timed 240 "$out/quick.txt" $joca run --preset quick --device cuda --out "$work/quick"
cp "$work/quick/results.json" "$out/quick-results.json" 2>/dev/null
for i in 1 2; do
  timed 60 "$out/repeat.txt" $joca eval "$work/quick" --device cuda --town 2 --frames 20
  grep -o '"map": [0-9.e-]*' "$work/quick/results-town2.json" | head -1 >>"$out/repeat.txt"
done
printf '[run]\ngenerations = 1\n' >"$work/one-generation.toml"
timed 200 "$out/standard.txt" $joca run --preset standard --device cuda \
  --config "$work/one-generation.toml" --out "$work/standard"
echo "candidates finished: $(grep -c 'done: fitness' "$out/standard.txt")" >>"$out/standard.txt"
ls "$out"
