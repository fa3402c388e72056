#!/usr/bin/env bash
# Renders an HTML report in headless Chromium (Debian's `chromium`, installed if missing), takes a
# screenshot and fails on any console message. It first checks on a page with a deliberate
# console error that this Chromium reports such messages at all, so a silent browser cannot pass.
# Without arguments it makes a report from scripts/slurm-tiny.toml's grid (about 20 s).
# Usage: scripts/test-report-html.sh [REPORT.html [SCREENSHOT.png]]
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
if ! command -v chromium >/dev/null; then
  echo "test-report-html: installing chromium"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends chromium >/dev/null
fi
work="$(mktemp -d /tmp/joca-html.XXXXXX)"
report="${1:-}"
shot="${2:-$work/report.png}"
if [ -z "$report" ]; then
  scripts/bootstrap-libtorch.sh >&2
  cargo build --quiet --profile ci -p joca-cli
  target/ci/joca experiment scripts/slurm-tiny.toml --out "$work/exp" --jobs 2 >/dev/null
  report="$work/exp/report.html"
fi
report="$(cd "$(dirname "$report")" && pwd)/$(basename "$report")"

render() { # html png -> console lines on stdout
  timeout 120 chromium --headless --no-sandbox --disable-gpu --hide-scrollbars \
    --window-size=1300,3000 --screenshot="$2" --enable-logging=stderr --v=0 "file://$1" 2>&1 \
    | grep -E "CONSOLE|Uncaught" || true
}

printf '<!DOCTYPE html><html><body><script>console.error("deliberate")</script></body></html>' > "$work/bad.html"
if [ -z "$(render "$work/bad.html" "$work/bad.png")" ]; then
  echo "test-report-html: this Chromium does not report console messages; cannot check" >&2
  exit 1
fi

# Self-contained: every src/href is a data: URI or an in-page anchor.
if grep -oE '(src|href)="[^"#][^"]{0,20}' "$report" | grep -v '="data:' ; then
  echo "test-report-html: $report refers to external resources (above)" >&2
  exit 1
fi
console="$(render "$report" "$shot")"
if [ -n "$console" ]; then
  echo "test-report-html: console messages while rendering $report:" >&2
  echo "$console" >&2
  exit 1
fi
size=$(stat -c %s "$shot")
if [ "$size" -lt 20000 ]; then
  echo "test-report-html: screenshot $shot is only $size bytes" >&2
  exit 1
fi
echo "test-report-html: ok — $report rendered with no console messages; screenshot $shot ($size bytes)"
