"""The cost of a solve from Python against the command line's, measured in one run (a benchmark,
not a timed test: docs/python.md, "Cost"). For each definition, the median of N rounds of:
  module:  crosslink.solve(m), every channel read as an array;
  command: `crosslink solve FILE --format csv` in a subprocess, its CSV parsed into arrays.
Usage: PYTHONPATH=build/python /usr/bin/python3 bench/python_solve.py [N] [DEFINITION...]"""
import io
import statistics
import subprocess
import sys
import time

import numpy as np

import crosslink

BINARY = "build/app/crosslink"


def module_solve(path):
    solution = crosslink.solve(crosslink.load(path))
    return {name: solution[name] for name in solution.channels}


def command_solve(path):
    text = subprocess.run([BINARY, "solve", path, "--format", "csv"], capture_output=True,
                          text=True, check=True).stdout
    table = np.genfromtxt(io.StringIO(text), delimiter=",", names=True, dtype=None,
                          encoding="utf-8")
    return {name: table[name] for name in table.dtype.names}


def median_seconds(call, path, rounds):
    times = []
    for _ in range(rounds):
        start = time.perf_counter()
        call(path)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main():
    rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    paths = sys.argv[2:] or ["mechanisms/fourbar_crank_rocker.toml", "mechanisms/jansen_leg.toml"]
    print(f"{'definition':<44} {'module [s]':>11} {'command+CSV [s]':>16} {'ratio':>7}")
    for path in paths:
        module = median_seconds(module_solve, path, rounds)
        command = median_seconds(command_solve, path, rounds)
        print(f"{path:<44} {module:>11.4f} {command:>16.4f} {command / module:>7.1f}")


if __name__ == "__main__":
    main()
