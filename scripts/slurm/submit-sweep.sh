#!/bin/bash
# Submits a crosslink sweep as a Slurm array job of N shards and its merge, which starts when
# every shard has ended well (docs/sweep.md, "On a Slurm cluster").
#   usage: scripts/slurm/submit-sweep.sh N OUTDIR SWEEP-ARGUMENTS...
#   e.g.   scripts/slurm/submit-sweep.sh 8 out/sweep mechanisms --engines mujoco,bullet
# Prints the two job ids. SBATCH_OPTIONS: more sbatch options for both jobs (e.g. a partition,
# --time); WAIT=1: return when the merge has ended, with its exit code (the test uses it).
# CROSSLINK: the crosslink executable the jobs run (default: crosslink on the PATH); OUTDIR and
# the definitions must be on a file system every node sees.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
n=$1
out=$2
shift 2
case $n in '' | *[!0-9]* | 0) echo "submit-sweep.sh: N must be a positive count, got '$n'" >&2; exit 2 ;; esac
mkdir -p "$out"
read -r -a extra <<<"${SBATCH_OPTIONS:-}"
array=$(sbatch --parsable "${extra[@]}" --array=0-$((n - 1)) --chdir="$PWD" \
  --output="$out/sweep-%a.log" "$here/sweep-array.sbatch" "$out" "$@")
array=${array%%;*}  # "id;cluster" on a federation
wait=()
[ "${WAIT:-0}" = 1 ] && wait=(--wait)
echo "array job $array: $n shards, parts in $out"
merge=$(sbatch --parsable "${extra[@]}" "${wait[@]}" --dependency=afterok:"$array" \
  --kill-on-invalid-dep=yes --chdir="$PWD" --output="$out/merge.log" \
  "$here/sweep-merge.sbatch" "$out")
echo "merge job ${merge%%;*}: $out/sweep.csv, sweep.html, sweep.json"
