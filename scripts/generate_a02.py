#!/usr/bin/env python3
"""Writes IFToMM A02, the N four-bar mechanism, as a crosslink definition for any N.

Usage: scripts/generate_a02.py N [DURATION] > mechanisms/iftomm_a02_nfourbar_N.toml
The bundled N = 10 and N = 40 files were written by it; N = 2 is written out by hand in
mechanisms/iftomm_a02_double_fourbar.toml (the same model: this script reproduces it but for
its comments and joint names).
"""
import sys


def main() -> None:
    n = int(sys.argv[1])
    duration = float(sys.argv[2]) if len(sys.argv) > 2 else 10.0
    if n < 1:
        sys.exit("N must be at least 1")
    bar = 'mass = 1\ncom = [0.5, 0]\ninertia = 0.083333333333333333\n'
    out = [
        f"# IFToMM multibody benchmark A02, the N four-bar mechanism, with N = {n}: {2 * n + 1} bars of",
        "# 1 m and 1 kg (uniform rods), cranks A_i B_i upright at x = i m, couplers B_(i-1) B_i",
        "# horizontal; gravity 9.81 m/s^2 along -y; B0 starts at 1 m/s along +x.",
        "# Written by scripts/generate_a02.py; see mechanisms/iftomm_a02_double_fourbar.toml (N = 2).",
        f'name = "IFToMM A02: N four-bar mechanism, N = {n}"',
        'citation = "IFToMM Technical Committee for Multibody Dynamics, library of computational '
        "benchmark problems, problem A02 'N four-bar mechanism' (M. Gonzalez, D. Dopico, U. Lugris, "
        'J. Cuadrado, A benchmarking system for MBS simulation software, Multibody System Dynamics '
        f'16 (2006) 179-190); N = {n}"',
        'description = "The tip of the first crank is B0. Free motion under gravity from the upright position."',
        "gravity = [0, -9.81]",
        "",
        "[units]",
        'length = "m"',
        'angle = "deg"',
        "",
        "[[link]]",
        'name = "ground"',
        "ground = true",
        "points = { " + ", ".join(f"A{i} = [{i}, 0]" for i in range(n + 1)) + " }",
    ]
    for i in range(n + 1):
        out += ["", "[[link]]", f'name = "crank{i}"', f"points = {{ A{i} = [0, 0], B{i} = [1, 0] }}",
                f"pose = [{i}, 0, 90]", bar.rstrip()]
    for i in range(1, n + 1):
        out += ["", "[[link]]", f'name = "coupler{i}"',
                f"points = {{ B{i - 1} = [0, 0], B{i} = [1, 0] }}", f"pose = [{i - 1}, 1, 0]",
                bar.rstrip()]
    for i in range(n + 1):
        out += ["", "[[joint]]", 'type = "revolute"', f'links = ["ground", "crank{i}"]',
                f'point = "A{i}"']
    for i in range(1, n + 1):
        # B_(i-1) joins coupler i to crank i-1; B_i joins coupler i to crank i.
        out += ["", "[[joint]]", 'type = "revolute"', f'name = "B{i - 1}c{i}"',
                f'links = ["crank{i - 1}", "coupler{i}"]', f'point = "B{i - 1}"']
        out += ["", "[[joint]]", 'type = "revolute"', f'name = "B{i}c{i}"',
                f'links = ["coupler{i}", "crank{i}"]', f'point = "B{i}"']
    out += ["", "[driver]", 'type = "joint_angle"', 'joint = "A0"', 'to = "B0"', "start = 90",
            "", "[dynamics]", f"duration = {duration:g}", "interval = 0.025", "rate = -1", ""]
    sys.stdout.write("\n".join(out))


if __name__ == "__main__":
    main()
