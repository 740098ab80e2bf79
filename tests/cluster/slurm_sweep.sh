#!/bin/bash
# The Slurm array job end to end (label `cluster`, docs/sweep.md "On a Slurm cluster"): starts
# its own one-node Slurm on this machine in a temporary folder (slurmctld and slurmd, free ports
# picked now, no munge: auth/none), submits scripts/slurm/submit-sweep.sh over every bundled
# definition at a cheap setting, waits for the merge, and holds the merged CSV and JSON to those
# of a single run of the same sweep, cost columns aside; then shuts Slurm down (on any exit).
# Without Slurm it fails: scripts/setup.sh installs it (slurm-wlm); without root, run the rest
# of the suite with `ctest -LE cluster`.
#   usage: slurm_sweep.sh CROSSLINK SOURCE_DIR
set -euo pipefail
crosslink=$(realpath "$1")
source_dir=$(realpath "$2")
shards=3
for tool in slurmctld slurmd sbatch sinfo scontrol python3; do
  command -v "$tool" >/dev/null || {
    echo "FAIL: $tool not found: install Slurm (scripts/setup.sh: slurm-wlm), or leave this" \
      "test out: ctest -LE cluster" >&2
    exit 1
  }
done

dir=$(mktemp -d /tmp/crosslink-slurm.XXXXXX)
pids=()
stop() {
  # The jobs first (their slurmstepd outlive slurmd), then the daemons.
  [ -n "${SLURM_CONF:-}" ] && { scancel --quiet --user "$(id -un)" 2>/dev/null; sleep 1; } || true
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$p" 2>/dev/null || break; sleep 0.1; done
    kill -9 "$p" 2>/dev/null || true
  done
  rm -rf "$dir"
}
trap stop EXIT

# Two free ports (the Release and the ASan suites run one after the other; never a fixed one).
read -r ctld_port slurmd_port < <(python3 -c '
import socket
s = [socket.socket() for _ in range(2)]
for x in s: x.bind(("127.0.0.1", 0))
print(*[x.getsockname()[1] for x in s])')
node=$(hostname -s)
user=$(id -un)
mkdir -p "$dir/state" "$dir/spool"
cat >"$dir/slurm.conf" <<CONF
ClusterName=crosslinktest
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=$user
SlurmdUser=$user
AuthType=auth/none
CredType=cred/none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
SwitchType=switch/none
MpiDefault=none
ReturnToService=2
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
SlurmctldTimeout=30
SlurmdTimeout=30
NodeName=$node NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=test Nodes=$node Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF=$dir/slurm.conf
slurmctld -D -c -i >"$dir/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -N "$node" >"$dir/slurmd.out" 2>&1 &
pids+=($!)
for i in $(seq 150); do
  state=$(sinfo -h -n "$node" -o %T 2>/dev/null || true)
  [ "$state" = idle ] && break
  if [ "$i" = 150 ]; then
    echo "FAIL: the node did not come up (state '$state')" >&2
    tail -n 20 "$dir"/slurmctld.log "$dir"/slurmd.log "$dir"/*.out >&2 || true
    exit 1
  fi
  sleep 0.2
done

# Every bundled definition but the scaling chains (mechanisms/scaling: A02 with N = 10 and 40
# four-bars, 47 s of CPU of the 72 s of all 27 at this setting), at a setting that takes
# seconds: one engine, one time step, one timing run, a 10-degree reference sweep (a dynamics
# case keeps its own interval).
cd "$source_dir"
mapfile -t definitions < <(find mechanisms -name '*.toml' -not -path '*/scaling/*' | sort)
sweep=("${definitions[@]}" --engines mujoco --dt 1e-3 --repeat 1 --step 10)
# A single run of the same sweep, meanwhile (the cores the shards leave idle).
"$crosslink" sweep "${sweep[@]}" --quiet --csv "$dir/single.csv" --json "$dir/single.json" \
  >/dev/null &
single=$!
pids+=("$single")
start=$(date +%s)
WAIT=1 CROSSLINK=$crosslink "$source_dir/scripts/slurm/submit-sweep.sh" "$shards" "$dir/out" \
  "${sweep[@]}" || {
  echo "FAIL: the Slurm jobs did not end well" >&2
  tail -n 30 "$dir"/out/*.log "$dir/slurmctld.log" >&2 || true
  exit 1
}
echo "slurm: $shards shards and the merge in $(($(date +%s) - start)) s"
ls "$dir/out"
for k in $(seq 0 $((shards - 1))); do
  [ -s "$dir/out/part-$k.json" ] || { echo "FAIL: no part $k" >&2; exit 1; }
done

rc=0
wait "$single" || rc=$?
[ "$rc" -le 1 ] || { echo "FAIL: the single run exited $rc" >&2; exit 1; }
echo "the single run ended $(($(date +%s) - start)) s after the submission"

# Identical apart from costs: the cost columns and keys, and the timings in the analytic rows'
# messages ("...; 0.0011 s").
python3 - "$dir/single.csv" "$dir/out/sweep.csv" "$dir/single.json" "$dir/out/sweep.json" <<'PY'
import csv, json, re, sys
COST = {'wall_s_per_cycle', 'cpu_s_per_cycle', 'rank'}  # rank: engines ordered by CPU time
def timing(s): return re.sub(r'; [0-9.e+-]+ s\b', '; T s', s)
def table(path):
    rows = list(csv.reader(open(path)))
    keep = [i for i, name in enumerate(rows[0]) if name not in COST]
    return [[timing(r[i]) for i in keep] for r in rows]
def strip(j):
    if isinstance(j, dict): return {k: strip(v) for k, v in j.items() if k not in COST}
    if isinstance(j, list): return [strip(v) for v in j]
    return timing(j) if isinstance(j, str) else j
a, b = table(sys.argv[1]), table(sys.argv[2])
definitions = {r[0] for r in a[1:]}
assert a[0][0] == 'definition' and len(definitions) >= 25, (a[0], len(definitions))
if a != b:
    bad = [(x, y) for x, y in zip(a, b) if x != y][:3]
    sys.exit(f'FAIL: the merged CSV differs from the single run\'s ({len(a)} and {len(b)} rows): {bad}')
if strip(json.load(open(sys.argv[3]))) != strip(json.load(open(sys.argv[4]))):
    sys.exit('FAIL: the merged JSON differs from the single run\'s')
print(f'identical apart from costs: {len(a) - 1} rows over {len(definitions)} definitions')
PY
