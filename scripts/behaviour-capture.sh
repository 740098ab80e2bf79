#!/bin/bash
# Capture `crosslink compare` (console, --json, --csv) on every bundled definition, so that a
# behaviour-neutral change can be checked against main with scripts/behaviour-diff.py.
# usage: scripts/behaviour-capture.sh CROSSLINK OUTDIR
set -u
bin=$(realpath "$1"); out=$2; mkdir -p "$out"; out=$(realpath "$out")
cd "$(dirname "$0")/.."
for f in $(find mechanisms -name '*.toml' | sort); do
  case $f in *nfourbar_40*) continue ;; esac # minutes of engine time; N = 10 covers the chain
  n=$(echo "$f" | tr '/' '_')
  "$bin" compare "$f" --json "$out/$n.json" --csv "$out/$n.csv" >"$out/$n.txt" 2>"$out/$n.err"
  echo "rc=$?" >>"$out/$n.txt"
done
