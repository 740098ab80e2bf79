#!/bin/bash
# Capture `crosslink compare` (console, --json, --csv), `check` and `solve --format json` on every
# bundled definition, so that a behaviour-neutral change can be checked against main with
# scripts/behaviour-diff.py.
# usage: scripts/behaviour-capture.sh CROSSLINK OUTDIR
set -u
bin=$(realpath "$1"); out=$2; mkdir -p "$out"; out=$(realpath "$out")
cd "$(dirname "$0")/.."
for f in $(find mechanisms -name '*.toml' | sort); do
  case $f in *nfourbar_40*) continue ;; esac # minutes of engine time; N = 10 covers the chain
  n=$(echo "$f" | tr '/' '_')
  "$bin" compare "$f" --json "$out/$n.json" --csv "$out/$n.csv" >"$out/$n.txt" 2>"$out/$n.err"
  echo "rc=$?" >>"$out/$n.txt"
  "$bin" check "$f" >"$out/$n.check.txt" 2>&1
  echo "rc=$?" >>"$out/$n.check.txt"
  "$bin" solve "$f" --format json >"$out/$n.solve.json" 2>"$out/$n.solve.err"
done
