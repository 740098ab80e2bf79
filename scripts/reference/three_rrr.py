#!/usr/bin/env python3
"""3-RRR planar parallel manipulator: the drivers' tables of
mechanisms/drivers/three_rrr_rose.toml and three_rrr_turning.toml from the
inverse kinematics (standard library only). Writes both files.

Dimensions (metres), transcribed from nopour/3RRR-mechanism, RIGID/Inv2.m
(commit 6705f966): b = 0.90 (base triangle side), a = 0.08 (platform triangle
side), l1 = l2 = 0.40 (proximal, distal links);
    base pivots A1 = (-b/2, -sqrt(3) b/6), A2 = (b/2, -sqrt(3) b/6),
                A3 = (0, sqrt(3) b/3)
    platform    C_i = P + R(phi) c_i, c1 = (-a/2, -sqrt(3) a/6),
                c2 = (a/2, -sqrt(3) a/6), c3 = (0, sqrt(3) a/3)
Paths:
    rose:    x = r0 sin(12 pi t) cos(4 pi t), y = 0.25 + r0 sin(12 pi t) sin(4 pi t),
             phi = 0, r0 = 0.1, t in [0, 0.25] (Inv2.m's q11, q22, q_3)
    turning: P = (0, 0.25), phi = t (1 rad/s), t in [0, 3] (chosen here: it crosses a
             direct singularity at t = 2.383692193572 s in this working mode)
Actuated: the proximal links' absolute angles theta_i at A_i, working mode
"+++" (chosen here): theta_i = psi_i + acos(|C_i - A_i| / (2 l1)), psi_i the
angle of C_i - A_i (each elbow B_i left of A_i -> C_i).
Each table holds its knots on [0, T] and 10 more beyond each end (the path's
own formula continued), so that the natural spline's end condition falls
outside the swept interval.
"""
import math
import os

B_SIDE, A_SIDE, L1, L2 = 0.90, 0.08, 0.40, 0.40
S3 = math.sqrt(3.0)
BASE = [(-B_SIDE / 2, -S3 * B_SIDE / 6), (B_SIDE / 2, -S3 * B_SIDE / 6), (0.0, S3 * B_SIDE / 3)]
PLAT = [(-A_SIDE / 2, -S3 * A_SIDE / 6), (A_SIDE / 2, -S3 * A_SIDE / 6), (0.0, S3 * A_SIDE / 3)]
PAD = 10


def rose(t):
    sr = math.sin(12 * math.pi * t)
    return (0.1 * sr * math.cos(4 * math.pi * t), 0.25 + 0.1 * sr * math.sin(4 * math.pi * t), 0.0)


def turning(t):
    return (0.0, 0.25, t)


def platform_points(pose):
    x, y, phi = pose
    c, s = math.cos(phi), math.sin(phi)
    return [(x + c * px - s * py, y + s * px + c * py) for px, py in PLAT]


def ik(pose):
    """theta_i, B_i, C_i in mode +++."""
    out = []
    for (ax, ay), (cx, cy) in zip(BASE, platform_points(pose)):
        dx, dy = cx - ax, cy - ay
        rho = math.hypot(dx, dy)
        th = math.atan2(dy, dx) + math.acos((rho * rho + L1 * L1 - L2 * L2) / (2 * L1 * rho))
        out.append((th, (ax + L1 * math.cos(th), ay + L1 * math.sin(th)), (cx, cy)))
    return out


def table(path, duration, knots):
    h = duration / (knots - 1)
    times = [k * h for k in range(-PAD, knots + PAD)]
    rows = [[], [], []]
    last = None
    for t in times:
        th = [leg[0] for leg in ik(path(t))]
        if last is not None:  # continuous angles
            th = [v + 2 * math.pi * round((p - v) / (2 * math.pi)) for v, p in zip(th, last)]
        last = th
        for i in range(3):
            rows[i].append((t, math.degrees(th[i])))
    return rows


def mm(p):
    return f"[{p[0] * 1000:.12g}, {p[1] * 1000:.12g}]"


def write(name, title, citation, description, path, duration, knots):
    legs = ik(path(0.0))
    x, y, phi = path(0.0)
    rows = table(path, duration, knots)
    o = [f'name = "{title}"', f'citation = "{citation}"', f'description = """\n{description}"""',
         "", "[units]", 'length = "mm"', 'angle = "deg"', "", "[[link]]", 'name = "ground"',
         "ground = true",
         "points = { " + ", ".join(f"A{i + 1} = {mm(BASE[i])}" for i in range(3)) + " }"]
    for i, (th, b, c) in enumerate(legs):
        n = i + 1
        distal = math.degrees(math.atan2(c[1] - b[1], c[0] - b[0]))
        o += ["", "[[link]]", f'name = "proximal{n}"', f"points = {{ A{n} = [0, 0], B{n} = [400, 0] }}",
              f"pose = [{BASE[i][0] * 1000:.12g}, {BASE[i][1] * 1000:.12g}, {math.degrees(th):.12g}]",
              "", "[[link]]", f'name = "distal{n}"', f"points = {{ B{n} = [0, 0], C{n} = [400, 0] }}",
              f"pose = [{b[0] * 1000:.12g}, {b[1] * 1000:.12g}, {distal:.12g}]"]
    o += ["", "[[link]]", 'name = "platform"',
          "points = { P = [0, 0], " + ", ".join(f"C{i + 1} = {mm(PLAT[i])}" for i in range(3)) + " }",
          f"pose = [{x * 1000:.12g}, {y * 1000:.12g}, {math.degrees(phi):.12g}]"]
    for n in (1, 2, 3):
        for a, b, p in ((("ground", f"proximal{n}", f"A{n}")), (f"proximal{n}", f"distal{n}", f"B{n}"),
                        (f"distal{n}", "platform", f"C{n}")):
            o += ["", "[[joint]]", 'type = "revolute"', f'links = ["{a}", "{b}"]', f'point = "{p}"']
    for i in range(3):
        n = i + 1
        o += ["", "[[driver]]", f'name = "theta{n}"', 'type = "joint_angle"', f'joint = "A{n}"',
              f'to = "B{n}"', f"start = {rows[i][PAD][1]!r}", f"duration = {duration:g}",
              "table = ["]
        o += [f"  [{t!r}, {v!r}]," for t, v in rows[i]]
        o += ["]"]
    here = os.path.dirname(os.path.abspath(__file__))
    with open(os.path.join(here, "..", "..", "mechanisms", "drivers", name), "w") as f:
        f.write("\n".join(o) + "\n")


CITATION = ("the 3RRR-mechanism code of R. Nopour on GitHub, Inv2.m of its rigid model (commit 6705f966): a = 8e-2, b = 90e-2, "
            "l1 = l2 = 40e-2 m, accompanying R. Nopour, M. M. Aghdam, A. Taghvaeipour, Nonlinear "
            "Analysis of Flexible Parallel Mechanisms Through Bezier-Based Integration, Springer "
            "2024 (doi 10.1007/978-3-031-53582-6_3; the code was read, not the papers)")

if __name__ == "__main__":
    write("three_rrr_rose.toml", "3-RRR planar parallel manipulator on a three-petal rose",
          CITATION + "; working mode +++ chosen here; tables from the inverse kinematics",
          "A platform triangle of 80 mm side on three legs of two 400 mm links each, pivoted at\n"
          "the corners of a 900 mm base triangle; each proximal link driven at its base pivot.\n"
          "The platform centre follows the source's three-petal rose of 100 mm radius about\n"
          "(0, 250) mm at constant orientation in 0.25 s: each driver's table is the inverse\n"
          "kinematics at 961 knots over the cycle and 10 beyond each end (working mode +++,\n"
          "each elbow left of A_i -> C_i). No singular position on the way. Masses: the default\n"
          "bar model.\n",
          rose, 0.25, 961)
    write("three_rrr_turning.toml", "3-RRR planar parallel manipulator turning through a direct singularity",
          CITATION + "; path and working mode +++ chosen here; tables from the inverse kinematics",
          "The manipulator of three_rrr_rose.toml with its platform centre held at (0, 250) mm\n"
          "while the platform turns at 1 rad/s for 3 s. At t = 2.383692193572 s the three distal\n"
          "links' lines meet in one point (a direct, or parallel, singularity: the drivers stop\n"
          "determining the platform's turn). Tables: the inverse kinematics at 601 knots over\n"
          "the 3 s and 10 beyond each end (working mode +++).\n",
          turning, 3.0, 601)
