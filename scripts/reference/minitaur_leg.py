#!/usr/bin/env python3
"""Minitaur five-bar leg: toe position, velocity, acceleration and the drivers'
torques under a toe load, in closed form (numpy only).

Dimensions (metres), transcribed from bulletphysics/bullet3,
examples/pybullet/gym/pybullet_envs/minitaur/agents/baseline_controller/
minitaur_raibert_controller_utils.py (commit 4d34ba73):
    UPPER_LEG_LEN = 0.112        hip -> knee (each motor's crank, l1)
    LOWER_SHORT_LEG_LEN = 0.199  knee -> ankle (both lower links, l2)
    LOWER_LONG_LEG_LEN = 0.2315  knee -> toe along the long lower link (l3)
Both motors turn about the same hip axis (the ground link has zero length).

Model here (world frame, y up, hip at the origin):
    knee_i = l1 (cos q_i, sin q_i), i = 1 (long lower link), 2 (short)
    ankle  = the intersection of the circles (knee_1, l2), (knee_2, l2) on the
             right of the direction knee_1 -> knee_2 (the source's mode)
    toe    = knee_1 + (l3 / l2) (ankle - knee_1)
Drivers: q1, q2 are the absolute angles of the two upper links (CCW, rad).
Torques: massless leg, external force F on the toe; the drivers' torques (on
each upper link from the ground, CCW +) that hold it are tau = -J^T F,
J = d toe / d (q1, q2).
Independent checks: the source's own forward-kinematics formula
(leg_pose_to_foot_position) and central finite differences.
"""
import math

import numpy as np

L1, L2, L3 = 0.112, 0.199, 0.2315   # bullet3 pybullet Minitaur model
MODELS = {
    # koduino (avikde/koduino, MinitaurLeg.cpp): "defaults are for minitaur"
    "koduino": (0.1, 0.2, 0.2),
    "bullet3": (0.112, 0.199, 0.2315),
}


def e(a):
    return np.array([math.cos(a), math.sin(a)])


def n(a):
    return np.array([-math.sin(a), math.cos(a)])


def cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


def kin(q, qd, qdd):
    """Toe position, velocity, acceleration; lower-link angles and rates."""
    k1, k2 = L1 * e(q[0]), L1 * e(q[1])
    k1d, k2d = L1 * qd[0] * n(q[0]), L1 * qd[1] * n(q[1])
    k1dd = L1 * (qdd[0] * n(q[0]) - qd[0] ** 2 * e(q[0]))
    k2dd = L1 * (qdd[1] * n(q[1]) - qd[1] ** 2 * e(q[1]))
    d = k2 - k1
    dist = math.hypot(*d)
    h = math.sqrt(L2 ** 2 - (dist / 2) ** 2)
    mid = k1 + d / 2
    perp = np.array([-d[1], d[0]]) / dist
    # assembly mode of the source: the ankle is on the right of knee_1 ->
    # knee_2 (below the knees when knee_1 is the left one)
    ankle = mid - h * perp
    phi1 = math.atan2(*(ankle - k1)[::-1])
    phi2 = math.atan2(*(ankle - k2)[::-1])
    # velocity: k1d + L2 w1 n1 = k2d + L2 w2 n2
    A = np.column_stack([L2 * n(phi1), -L2 * n(phi2)])
    w1, w2 = np.linalg.solve(A, k2d - k1d)
    # acceleration: k1dd + L2 (a1 n1 - w1^2 e1) = k2dd + L2 (a2 n2 - w2^2 e2)
    rhs = k2dd - k1dd + L2 * w1 ** 2 * e(phi1) - L2 * w2 ** 2 * e(phi2)
    a1, a2 = np.linalg.solve(A, rhs)
    toe = k1 + L3 * e(phi1)
    toed = k1d + L3 * w1 * n(phi1)
    toedd = k1dd + L3 * (a1 * n(phi1) - w1 ** 2 * e(phi1))
    return toe, toed, toedd, ankle, (phi1, phi2, w1, w2, a1, a2)


def jacobian(q):
    c1 = kin(q, [1.0, 0.0], [0.0, 0.0])[1]
    c2 = kin(q, [0.0, 1.0], [0.0, 0.0])[1]
    return np.column_stack([c1, c2])


def source_fk(leg_pose):
    """bullet3's leg_pose_to_foot_position, transcribed (swing, extension)."""
    l1, l2, l3 = L1, L2, L3
    ext = leg_pose[1]
    alpha = math.asin(l1 * math.sin(ext) / l2)
    sw = -leg_pose[0]
    x = l3 * math.sin(alpha + sw) - l1 * math.sin(ext + sw)
    y = l3 * math.cos(alpha + sw) - l1 * math.cos(ext + sw)
    return (x, -y)


def koduino_fk_ext(m):
    """koduino MinitaurLeg::FKext, transcribed: toe distance from the hip."""
    l1proj = L1 * math.sin(m)
    return math.sqrt(L2 * L2 - l1proj * l1proj) - L1 * math.cos(m)


def koduino_dfk(m):
    """koduino's Jacobian term (getSpeed: DFKext = l1proj (1 - term2/term1))."""
    l1proj = L1 * math.sin(m)
    term1 = math.sqrt(L2 * L2 - l1proj * l1proj)
    term2 = L1 * math.cos(m)
    return l1proj * (1 - term2 / term1)


def check_against_koduino():
    """Map: m = (q1 - q2)/2 (half the angle between the upper links, 0 when
    both point straight away from the toe), leg direction -pi/2 + theta,
    theta = (q1 + q2)/2 - pi/2.  Check |toe| = FKext, the toe's direction,
    and d|toe|/dm = DFKext."""
    worst = 0.0
    for th in np.linspace(-0.6, 0.6, 7):
        for m in np.linspace(0.3, 2.8, 11):
            q1 = math.pi / 2 + th + m
            q2 = math.pi / 2 + th - m
            toe = kin([q1, q2], [0, 0], [0, 0])[0]
            ref = koduino_fk_ext(m) * np.array([math.sin(th), -math.cos(th)])
            # d|toe|/dm with q1' = +1, q2' = -1 (theta held)
            v = kin([q1, q2], [1.0, -1.0], [0, 0])[1]
            drdm = v @ toe / math.hypot(*toe)
            worst = max(worst, float(np.max(np.abs(toe - ref))),
                        abs(drdm - koduino_dfk(m)))
    return worst


def check_against_source():
    """Find the map (swing, extension) -> (q1, q2) and check the toe."""
    worst = 0.0
    for sw in np.linspace(-0.6, 0.6, 7):
        for ext in np.linspace(0.4, 2.6, 9):
            # the source's long-link knee is at (-sin(ext+sw'), cos(ext+sw'))
            # l1 with sw' = -swing, i.e. at angle pi/2 + ext + sw'
            swp = -sw
            q1 = math.pi / 2 + ext + swp
            q2 = math.pi / 2 - ext + swp
            toe = kin([q1, q2], [0, 0], [0, 0])[0]
            ref = np.array(source_fk((sw, ext)))
            worst = max(worst, float(np.max(np.abs(toe - ref))))
    return worst


def main():
    global L1, L2, L3
    for name, dims in MODELS.items():
        L1, L2, L3 = dims
        print(f"\n######## model {name}: l1 = {L1}, l2 = {L2}, l3 = {L3} m ########")
        if name == "koduino":
            print("max |toe - koduino FKext| and |d|toe|/dm - DFKext| over a 7x11"
                  f" grid: {check_against_koduino():.3e}")
            print("map: q1 = pi/2 + theta + m, q2 = pi/2 + theta - m")
        else:
            print("max |toe - bullet3 FK| over a 7x9 grid of (swing, extension): "
                  f"{check_against_source():.3e} m")
            print("map: q1 = pi/2 + extension - swing, q2 = pi/2 - extension - swing")
        run_laws()


def run_laws():
    F = np.array([0.0, 50.0])  # ground reaction on the toe, N (upward)
    # knees at 150 deg (q1) and 30 deg (q2): the upper links 120 deg apart
    # above the hip (bullet3 extension 60 deg, swing 0; koduino m = 60 deg,
    # theta = 0); A: rigid swing of the whole leg, B: the upper links open
    laws = {
        "A": ((math.radians(150.0), 2.0), (math.radians(30.0), 2.0)),
        "B": ((math.radians(150.0), 3.0), (math.radians(30.0), -1.0)),
    }
    for name, ((a, w1), (b, w2)) in laws.items():
        print(f"\nlaw {name}: q1 = {math.degrees(a):.1f} deg + {w1} rad/s t, "
              f"q2 = {math.degrees(b):.1f} deg + {w2} rad/s t (alphas 0); "
              f"toe load F = {F} N")
        for t in (0.0, 0.1, 0.25, 0.4):
            q = [a + w1 * t, b + w2 * t]
            qd = [w1, w2]
            toe, toed, toedd, ankle, _ = kin(q, qd, [0.0, 0.0])
            J = jacobian(q)
            tau = -J.T @ F
            # finite-difference checks of velocity and acceleration in time
            hh = 1e-5
            pp = kin([a + w1 * (t + hh), b + w2 * (t + hh)], qd, [0, 0])
            pm = kin([a + w1 * (t - hh), b + w2 * (t - hh)], qd, [0, 0])
            fd_v = (pp[0] - pm[0]) / (2 * hh)
            fd_a = (pp[1] - pm[1]) / (2 * hh)
            print(f" t={t:.2f} s  q=({q[0]:.12f}, {q[1]:.12f}) rad")
            print(f"   toe  = ({toe[0]:.12f}, {toe[1]:.12f}) m"
                  f"   ankle = ({ankle[0]:.12f}, {ankle[1]:.12f}) m")
            print(f"   v    = ({toed[0]:.12f}, {toed[1]:.12f}) m/s"
                  f"   [fd diff {np.max(np.abs(fd_v - toed)):.1e}]")
            print(f"   a    = ({toedd[0]:.12f}, {toedd[1]:.12f}) m/s^2"
                  f"   [fd diff {np.max(np.abs(fd_a - toedd)):.1e}]")
            # virtual work with a finite-difference Jacobian of the position
            Jfd = np.column_stack([
                (kin([q[0] + hh, q[1]], qd, [0, 0])[0]
                 - kin([q[0] - hh, q[1]], qd, [0, 0])[0]) / (2 * hh),
                (kin([q[0], q[1] + hh], qd, [0, 0])[0]
                 - kin([q[0], q[1] - hh], qd, [0, 0])[0]) / (2 * hh)])
            tau_fd = -Jfd.T @ F
            print(f"   tau  = ({tau[0]:.12f}, {tau[1]:.12f}) N m"
                  f"   [fd virtual work diff {np.max(np.abs(tau_fd - tau)):.1e}]")


if __name__ == "__main__":
    main()
