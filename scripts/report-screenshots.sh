#!/bin/bash
# The screenshots in docs/report.md, from a bundled definition's report: the page's top (the
# drawing and the first charts) and its derived table alone (the rest of the page hidden).
# usage: scripts/report-screenshots.sh CROSSLINK [DEFINITION]   (needs chromium)
set -euo pipefail
bin=$(realpath "$1"); definition=${2:-mechanisms/slider_crank_offset.toml}
cd "$(dirname "$0")/.."
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
"$bin" compare "$definition" --report "$work/report.html" >/dev/null
flags=(--headless --no-sandbox --disable-gpu --no-first-run --user-data-dir="$work/profile"
       --virtual-time-budget=20000 --hide-scrollbars)
out=$PWD/docs/figures
chromium "${flags[@]}" --window-size=1200,1700 --screenshot="$out/report_top.png" \
  "file://$work/report.html" 2>/dev/null
# The derived table alone: every other element of the body hidden.
sed 's|</head>|<style>body > * { display: none !important; } #derived, #derived + p { display: block !important; } #derived + p + table { display: table !important; }</style></head>|' \
  "$work/report.html" >"$work/derived.html"
chromium "${flags[@]}" --window-size=1200,${DERIVED_HEIGHT:-560} \
  --screenshot="$out/report_derived_table.png" \
  "file://$work/derived.html" 2>/dev/null
echo "docs/figures/report_top.png docs/figures/report_derived_table.png"
