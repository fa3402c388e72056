#!/usr/bin/env bash
# `joca report` over landed compact cells from several folders, a cell of a later folder replacing
# the same-named cell of an earlier one (as cells_table.py does), e.g. a panel's cells with its
# machine repeats in place of the originals. RUN_DIR gives the experiment (its experiment.json).
# Usage: report_cells.sh JOCA_BINARY RUN_DIR DEST_MD CELLS_DIR [CELLS_DIR ...]
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../../.."
bin=$1 run=$2 dest=$3
shift 3
tmp=$(mktemp -d)
cp "$run/experiment.json" "$run/.joca-output" "$tmp/"
mkdir -p "$tmp/cells"
for dir in "$@"; do
  for d in "$dir"/*/; do
    id=$(basename "$d")
    rm -rf "${tmp:?}/cells/$id"
    cp -r "$d" "$tmp/cells/$id"
    printf 'joca-output run\n' > "$tmp/cells/$id/.joca-output"
  done
done
"$bin" report "$tmp" >/dev/null
sed "s#\`$tmp\`#\`$*\` (later folders' cells replacing earlier ones)#g; s#$tmp#$1#g" \
  "$tmp/report.md" > "$dest"
rm -rf "$tmp"
echo "report: $dest"
