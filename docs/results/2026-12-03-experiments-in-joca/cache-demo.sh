#!/usr/bin/env bash
# The cache demo of issue 70, logged with each command.
set -u
cd /work/main
J=target/release/joca D=docs/results/2026-12-03-experiments-in-joca
rm -rf runs/cache-a runs/cache-b
run() { echo "\$ $*"; "$@" 2>&1 | tail -${TAILN:-12}; echo; }
echo "\$ joca experiment $D/cache-a.toml --preset quick --out runs/cache-a &   # killed below"
$J experiment $D/cache-a.toml --preset quick --out runs/cache-a > /tmp/cache-a-first.log 2>&1 &
sleep 100
cell=$(pgrep -f "joca cell runs/cache-a" | head -1)
echo "# after 100 s: SIGKILL to the cell process ($cell) and its parent"
kill -KILL $cell; sleep 1; pkill -KILL -f "experiment $D/cache-a.toml"; sleep 1
echo "# events.jsonl lines before the kill: $(wc -l < runs/cache-a/cells/average-calibrated-flir/events.jsonl)"
run $J experiment $D/cache-a.toml --preset quick --out runs/cache-a --status
TAILN=30 run $J experiment $D/cache-a.toml --preset quick --out runs/cache-a
run $J experiment $D/cache-b.toml --preset quick --out runs/cache-b --prepare --reuse runs/cache-a
run $J experiment $D/cache-b.toml --preset quick --out runs/cache-b --status
run cat runs/cache-b/cells/average-calibrated-flir/reused.json
run cmp runs/cache-a/cells/average-calibrated-flir/results.json runs/cache-b/cells/average-calibrated-flir/results.json
echo "done"
