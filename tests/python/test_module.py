"""The Python module against the command line (docs/python.md): the same library calls, so every
array equals the command's CSV to the bit, every flagged sample is masked where the CSV cell is
empty, and an error is the command's message."""
import csv
import glob
import io
import json
import os
import subprocess
import threading

import numpy as np
import pytest

import crosslink

BINARY = os.environ.get("CROSSLINK_BINARY", "build/app/crosslink")
# Every bundled kinematic definition (a dynamics case is simulated, not solved).
BUNDLED = sorted(
    path
    for path in glob.glob("mechanisms/**/*.toml", recursive=True)
    if "[dynamics]" not in open(path, encoding="utf-8").read()
)


def command(*args):
    return subprocess.run([BINARY, *args], capture_output=True, text=True, check=False)


def command_csv(path, *args):
    run = command("solve", path, "--format", "csv", *args)
    assert run.returncode == 0, run.stderr
    return list(csv.DictReader(io.StringIO(run.stdout)))


@pytest.mark.parametrize("path", BUNDLED)
def test_every_channel_is_the_commands_csv_to_the_bit(path):
    solution = crosslink.solve(crosslink.load(path))
    rows = command_csv(path)
    assert len(solution) == len(rows)
    assert solution.status == [row["status"] for row in rows]
    assert solution.channels == list(rows[0].keys())[4:]
    assert np.array_equal(solution.driver, [float(row["driver"]) for row in rows])
    for name in solution.channels:
        values = solution[name]
        cells = [row[name] for row in rows]
        # A value that does not exist is masked here and an empty cell there.
        assert list(np.ma.getmaskarray(values)) == [cell == "" for cell in cells], name
        for value, cell in zip(values.filled(np.nan), cells):
            if cell:
                assert value == float(cell), name  # %.17g reads back to the same double


def test_a_stored_channel_is_a_read_only_view_that_keeps_its_solution():
    solution = crosslink.solve(crosslink.load("mechanisms/fourbar_crank_rocker.toml"))
    x = solution["x.C"]
    assert not x.data.flags.owndata and not x.data.flags.writeable
    del solution  # the array still holds the trajectory
    assert np.isfinite(x.sum())
    with pytest.raises(ValueError):
        x.data[0] = 1.0


def test_units_are_si_as_the_json():
    assert crosslink.Solution.unit("x.C") == "m"
    assert crosslink.Solution.unit("angle.rocker") == "rad"
    assert crosslink.Solution.unit("omega.crank") == "rad/s"
    assert crosslink.Solution.unit("ay.B") == "m/s^2"
    assert crosslink.Solution.unit("torque.driver") == "N m"
    assert crosslink.Solution.unit("fx.A") == "N"


def test_one_pose_and_a_step_in_the_files_units():
    path = "mechanisms/fourbar_crank_rocker.toml"
    m = crosslink.load(path)
    pose = crosslink.solve(m, at=30)
    row = command_csv(path, "--at", "30")[0]
    assert len(pose) == 1
    assert pose["angle.rocker"][0] == float(row["angle.rocker"])
    coarse = crosslink.solve(m, step=10)
    assert len(coarse) == len(command_csv(path, "--step", "10"))


def test_a_definitions_error_is_the_commands_message():
    text = open("mechanisms/fourbar_crank_rocker.toml", encoding="utf-8").read()
    broken = text.replace('type = "revolute"', 'type = "revolut"', 1)
    with open("build/python_broken.toml", "w", encoding="utf-8") as out:
        out.write(broken)
    run = command("check", "build/python_broken.toml")
    assert run.returncode != 0
    with pytest.raises(crosslink.DefinitionError) as error:
        crosslink.load("build/python_broken.toml")
    assert str(error.value) in run.stderr
    assert "build/python_broken.toml:" in str(error.value)
    with pytest.raises(crosslink.DefinitionError) as from_text:
        crosslink.loads(broken, name="build/python_broken.toml")
    assert str(from_text.value) == str(error.value)
    assert isinstance(error.value, ValueError)


def test_a_pose_that_cannot_assemble_raises_the_commands_message():
    # The non-Grashof four-bar closes only between its toggles (tests/analytic/test_cli.cpp).
    path = "mechanisms/singular/fourbar_non_grashof.toml"
    run = command("solve", path, "--at", "100")
    assert run.returncode != 0
    with pytest.raises(crosslink.DefinitionError) as error:
        crosslink.solve(crosslink.load(path), at=100)
    assert "cannot_assemble at driver = 100 deg" in str(error.value)
    assert str(error.value) in run.stderr


def test_a_solve_releases_the_gil():
    # While one thread solves, this one runs Python: it counts through the solve, which it could
    # not do were the GIL held in it (the count would not move between the solve's two reads).
    m = crosslink.load("mechanisms/jansen_leg.toml")
    counter, seen, done = [0], [], threading.Event()

    def worker():
        before = counter[0]
        crosslink.solve(m)
        seen.append(counter[0] - before)
        done.set()

    thread = threading.Thread(target=worker)
    thread.start()
    while not done.is_set():
        counter[0] += 1
    thread.join()
    assert seen[0] > 1000, seen


def test_two_threads_solve_at_once():
    # Two threads at once each give the lone result.
    m = crosslink.load("mechanisms/jansen_leg.toml")
    alone = crosslink.solve(m, step=2)
    results = [None, None]

    def run(k):
        results[k] = crosslink.solve(m, step=2)

    threads = [threading.Thread(target=run, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in results:
        assert r.status == alone.status
        for name in alone.channels:
            assert np.array_equal(r[name].filled(np.nan), alone[name].filled(np.nan),
                                  equal_nan=True), name


def test_the_mechanism_and_the_engine_table():
    m = crosslink.load("mechanisms/fourbar_crank_rocker.toml")
    assert m.mobility == 1
    # Four links, four pins (Gruebler), as `check` prints it.
    assert m.mobility_text.endswith("= 3(4-1) - 2*4 - 0 = 1")
    assert m.mobility_text in command("check", "mechanisms/fourbar_crank_rocker.toml").stdout
    assert "crank" in m.links and "ground" in m.links
    listed = command("engines").stdout
    assert [e["name"] for e in crosslink.engines()] == ["mujoco", "bullet", "ode", "simbody"]
    for engine in crosslink.engines():
        assert engine["name"] in listed
        for setting in engine["settings"]:
            assert setting["name"] in listed


DYNAMICS = sorted(
    path
    for path in glob.glob("mechanisms/**/*.toml", recursive=True)
    if "[dynamics]" in open(path, encoding="utf-8").read()
)


@pytest.mark.parametrize("path", DYNAMICS)
def test_a_simulation_and_its_energies_are_the_commands_csv_to_the_bit(path):
    run = command("simulate", path, "--format", "csv")
    assert run.returncode == 0, run.stderr
    rows = list(csv.DictReader(io.StringIO(run.stdout)))
    simulation = crosslink.simulate(crosslink.load(path))
    assert simulation.status == [row["status"] for row in rows]
    assert np.array_equal(simulation.time, [float(row["time"]) for row in rows])
    columns = [(name, simulation[name]) for name in simulation.channels]
    columns += [("energy." + name, values) for name, values in simulation.energy.items()]
    for name, values in columns:
        cells = [row[name] for row in rows]
        assert list(np.ma.getmaskarray(values)) == [cell == "" for cell in cells], name
        for value, cell in zip(values.filled(np.nan), cells):
            if cell:
                assert value == float(cell), name


def without_wall_times(document):
    # A run's clock times (wall, CPU) are the one thing two runs of the same study differ in.
    if isinstance(document, dict):
        return {
            k: without_wall_times(v)
            for k, v in document.items()
            if not k.startswith("wall_") and not k.endswith("cpu_seconds")
        }
    if isinstance(document, list):
        return [without_wall_times(v) for v in document]
    return document


@pytest.mark.parametrize(
    "path, methods",
    [
        ("mechanisms/fourbar_crank_rocker.toml", "analytic,dyads,ic,mujoco,bullet,ode,simbody"),
        ("mechanisms/dynamics/double_pendulum_mbdyn.toml", "mujoco,simbody"),
        ("mechanisms/cams/curved_slot_rocker.toml", "mujoco,ode"),
    ],
)
def test_a_comparison_is_the_commands_json(path, methods):
    run = command("compare", path, "--engines", methods, "--json", "-")
    expected = json.loads(run.stdout)
    comparison = crosslink.compare(crosslink.load(path), methods=methods.split(","))
    assert without_wall_times(comparison.json) == without_wall_times(expected)
    assert comparison.passed == expected["pass"] == (run.returncode == 0)
    assert comparison.methods == [m["name"] for m in expected["methods"]]
    # Each method's trajectory, as its samples in the JSON's channels.
    for method in comparison.methods[1:]:
        trajectory = comparison[method]
        assert len(trajectory) == expected["samples"]


def test_compare_refuses_what_the_command_refuses():
    m = crosslink.load("mechanisms/fourbar_crank_rocker.toml")
    with pytest.raises(ValueError, match="no_such_setting"):
        crosslink.compare(m, methods=["mujoco"], settings=["mujoco:no_such_setting=1"])
    with pytest.raises(ValueError, match="not a dynamics case"):
        crosslink.simulate(m)


@pytest.mark.parametrize("path", sorted(glob.glob("mechanisms/**/*.toml", recursive=True)))
def test_check_is_the_commands_report(path):
    run = command("check", path)
    report = crosslink.check(crosslink.load(path))
    assert report["exit_code"] == run.returncode
    assert report["report"] == run.stdout
    assert report["errors"] == run.stderr
