"""A sweep's shards as Dask tasks (docs/python.md): a local dask.distributed cluster of worker
processes runs each shard with crosslink.sweep, and crosslink.merge joins the parts into the
document of one run, as `crosslink sweep --shard I/N` and `crosslink merge` do under Slurm."""
import json
import os
import re
import subprocess

import crosslink
from dask.distributed import Client, LocalCluster

BINARY = os.environ.get("CROSSLINK_BINARY", "build/app/crosslink")
# A kinematic definition, one with forces and a dynamics case, at one cheap setting (as
# Cli.MergedShardsWriteTheSweepOfOneRun).
DEFINITIONS = [
    "mechanisms/fourbar_crank_rocker.toml",
    "mechanisms/published/khurmi_slider_crank_gas_force.toml",
    "mechanisms/andrews_squeezer.toml",
]
OPTIONS = {"engines": ["mujoco"], "dts": [1e-3], "repeat": 1, "step": 10}


def without_costs(document):
    # The runs' clock times, and the text that quotes them, are what two runs differ in.
    if isinstance(document, dict):
        return {
            key: without_costs(value)
            for key, value in document.items()
            if key not in ("wall_s_per_cycle", "cpu_s_per_cycle") and "seconds" not in key
        }
    if isinstance(document, list):
        return [without_costs(value) for value in document]
    if isinstance(document, str):
        return re.sub(r"; [0-9.e+-]+ s\b", "; T s", document)
    return document


def sweep_shard(index, count):
    return crosslink.sweep(DEFINITIONS, shard=f"{index}/{count}", **OPTIONS)


def test_dask_shards_merge_into_the_document_of_one_run(tmp_path):
    single = crosslink.sweep(DEFINITIONS, **OPTIONS)
    cli = tmp_path / "single.json"
    run = subprocess.run(
        [BINARY, "sweep", *DEFINITIONS, "--engines", "mujoco", "--dt", "1e-3", "--repeat", "1",
         "--step", "10", "--quiet", "--json", str(cli)],
        capture_output=True, text=True, check=False)
    assert run.returncode == 0, run.stderr
    assert without_costs(single) == without_costs(json.loads(cli.read_text()))
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        parts = client.gather(client.map(sweep_shard, range(3), count=3))
    assert [part["shard"] for part in parts] == [{"index": k, "count": 3} for k in range(3)]
    merged = crosslink.merge(list(reversed(parts)))  # in any order
    assert without_costs(merged) == without_costs(single)
    # And a part the command wrote merges with the tasks' (the same document, whoever wrote it).
    shard0 = tmp_path / "part0.json"
    run = subprocess.run(
        [BINARY, "sweep", *DEFINITIONS, "--engines", "mujoco", "--dt", "1e-3", "--repeat", "1",
         "--step", "10", "--quiet", "--shard", "0/3", "--json", str(shard0)],
        capture_output=True, text=True, check=False)
    assert run.returncode == 0, run.stderr
    mixed = crosslink.merge([json.loads(shard0.read_text()), parts[1], parts[2]])
    assert without_costs(mixed) == without_costs(single)


def test_merge_refuses_parts_that_do_not_fit():
    part = crosslink.sweep(DEFINITIONS[:1], engines=["mujoco"], dts=[1e-3], repeat=1, step=10,
                           shard="0/2")
    try:
        crosslink.merge([part])
    except ValueError as error:
        assert "shard 1/2 is missing" in str(error)
    else:
        raise AssertionError("a missing shard merged")
