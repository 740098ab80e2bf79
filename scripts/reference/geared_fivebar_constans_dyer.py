#!/usr/bin/env python3
"""Geared five-bar A-B-E-C-D (gears at A and D) of E. Constans and K. B.
Dyer, "Introduction to Mechanism Design: with Computer Applications" (CRC
Press, 2018), the geared fivebar of chapters 4-6, as its figure appears in
ziolkowskid06/Introduction_to_Mechanism_Design_with_Computer_Application
("... - dimensions.PNG" in ch04/ch05/ch06: a picture of the book's problem
figure) with that repository's MATLAB solution: positions, rates,
accelerations, and the driver torque and mesh force of the massless linkage
under a load at P.

From the figure (all dimensions in millimetres):
    length of link on gear 1 (AB) 120, coupler 1 (BE) 250, coupler 2 (CE)
    250, length of link on gear 2 (DC) 120, distance between ground pins
    (AD) 180, B to P 200 at 20 deg from BE, C to Q 200 at 20 deg from CE,
    teeth on gear 1: 48, on gear 2: 24, angular velocity of gear 1: 10 rad/s,
    angular acceleration of gear 1: 0 rad/s^2 (ch06 figure).
From the MATLAB code (not in the figure): theta5 = -rho theta2 + phi,
rho = N1/N2, phi = 0; gamma3 = +20 deg (P), gamma4 = -20 deg (Q); the branch
delta = acos((b^2 + c^2 - f^2) / (2 b c)) in [0, pi], theta4 = theta3 +
delta (E above, as drawn).  The student's ch06 code uses alpha2 = 10 rad/s^2
(the figure says 0): both are printed below.
Gear pitch radii from the centre distance split in the teeth ratio:
    r1 = d N1 / (N1 + N2) = 0.120 m, r2 = d N2 / (N1 + N2) = 0.060 m.
"""
import math

import numpy as np

a, b, c, d, u = 0.120, 0.250, 0.250, 0.180, 0.120
N1, N2 = 48, 24
rho, phi0 = N1 / N2, 0.0
g3, g4 = math.radians(20.0), math.radians(-20.0)
p, q = 0.200, 0.200
r1, r2 = d * N1 / (N1 + N2), d * N2 / (N1 + N2)
XD = np.array([d, 0.0])


def e(t):
    return np.array([math.cos(t), math.sin(t)])


def n(t):
    return np.array([-math.sin(t), math.cos(t)])


def cross(x, y):
    return x[0] * y[1] - x[1] * y[0]


def source_angles(th2, th5):
    """The MATLAB position solution, transcribed."""
    xC = XD + u * e(th5)
    dprime = math.hypot(*xC)
    beta = math.atan2(xC[1], xC[0])
    r = dprime - a * math.cos(th2 - beta)
    s = a * math.sin(th2 - beta)
    f2 = r * r + s * s
    delta = math.acos((b * b + c * c - f2) / (2 * b * c))
    g = b - c * math.cos(delta)
    h = c * math.sin(delta)
    th3 = math.atan2(h * r - g * s, g * r + h * s) + beta
    return th3, th3 + delta


def solve(th2, th5, w2, w5, al2, al5):
    """Five-bar with both crank angles given: circle intersection for E."""
    B = a * e(th2)
    C = XD + u * e(th5)
    dv = C - B
    f = math.hypot(*dv)
    # E with |BE| = b, |CE| = c; branch: cross(E - B, E - C) > 0 (delta > 0)
    x = (b * b - c * c + f * f) / (2 * f)
    y = math.sqrt(b * b - x * x)
    ex = dv / f
    ey = np.array([-ex[1], ex[0]])
    E = None
    for sgn in (1, -1):
        cand = B + x * ex + sgn * y * ey
        if cross(cand - B, cand - C) > 0:
            E = cand
    th3 = math.atan2(*(E - B)[::-1])
    th4 = math.atan2(*(E - C)[::-1])
    # rates: B' + b w3 n3 = C' + c w4 n4
    Bd, Cd = a * w2 * n(th2), u * w5 * n(th5)
    Bdd = a * (al2 * n(th2) - w2 ** 2 * e(th2))
    Cdd = u * (al5 * n(th5) - w5 ** 2 * e(th5))
    M = np.column_stack([b * n(th3), -c * n(th4)])
    w3, w4 = np.linalg.solve(M, Cd - Bd)
    rhs = Cdd - Bdd + b * w3 ** 2 * e(th3) - c * w4 ** 2 * e(th4)
    al3, al4 = np.linalg.solve(M, rhs)
    P = B + p * e(th3 + g3)
    Q = C + q * e(th4 + g4)
    vP = Bd + p * w3 * n(th3 + g3)
    vQ = Cd + q * w4 * n(th4 + g4)
    aP = Bdd + p * (al3 * n(th3 + g3) - w3 ** 2 * e(th3 + g3))
    aQ = Cdd + q * (al4 * n(th4 + g4) - w4 ** 2 * e(th4 + g4))
    return dict(B=B, C=C, E=E, P=P, Q=Q, th3=th3, th4=th4, w3=w3, w4=w4,
                al3=al3, al4=al4, vP=vP, vQ=vQ, aP=aP, aQ=aQ, f=f)


def geared(th2, w2, al2):
    th5 = -rho * th2 + phi0
    return solve(th2, th5, w2, -rho * w2, al2, -rho * al2)


def main():
    w2, al2 = 10.0, 0.0
    F = np.array([0.0, -100.0])  # external load on P, N
    fmin = min(geared(t, 0, 0)["f"] for t in np.linspace(0, 2 * math.pi, 3601))
    print(f"pitch radii r1 = {r1:.6f} m, r2 = {r2:.6f} m; min |BC| over a turn"
          f" = {fmin:.6f} m (assembles for every theta2: needs 0 < |BC| < b + c)")
    worst = 0.0
    for t in np.linspace(0, 2 * math.pi, 361):
        s = geared(t, 0, 0)
        t3, t4 = source_angles(t, -rho * t + phi0)
        worst = max(worst, abs(math.remainder(t3 - s["th3"], 2 * math.pi)),
                    abs(math.remainder(t4 - s["th4"], 2 * math.pi)))
    print(f"max |angle - source's formula| over 361 crank angles: {worst:.2e} rad")
    for al in (al2, 10.0):
        print(f"\nomega2 = {w2} rad/s, alpha2 = {al} rad/s^2 "
              f"(omega5 = {-rho * w2}, alpha5 = {-rho * al}); load F = {F} N at P")
        for deg in (0, 30, 60, 120, 210, 300):
            t = math.radians(deg)
            s = geared(t, w2, al)
            # finite-difference checks along the crank angle
            hh = 1e-6
            sp, sm = geared(t + hh, w2, al), geared(t - hh, w2, al)
            fdv = (sp["P"] - sm["P"]) / (2 * hh) * w2
            fda = ((sp["vP"] - sm["vP"]) / (2 * hh) * w2
                   + (al / w2) * s["vP"] if w2 else 0)
            # massless statics: generalised forces of F w.r.t. theta2, theta5
            th5 = -rho * t + phi0
            dP2 = (solve(t + hh, th5, 0, 0, 0, 0)["P"]
                   - solve(t - hh, th5, 0, 0, 0, 0)["P"]) / (2 * hh)
            dP5 = (solve(t, th5 + hh, 0, 0, 0, 0)["P"]
                   - solve(t, th5 - hh, 0, 0, 0, 0)["P"]) / (2 * hh)
            # closed form: dP/dtheta2 and dP/dtheta5 are P's velocity for a
            # unit rate of one crank with the other held
            Q2 = F @ solve(t, th5, 1, 0, 0, 0)["vP"]
            Q5 = F @ solve(t, th5, 0, 1, 0, 0)["vP"]
            fdQ = max(abs(F @ dP2 - Q2), abs(F @ dP5 - Q5))
            tau2 = -Q2 + rho * Q5          # driver torque on crank 2, CCW +
            ft = Q5 / r2                   # tangential mesh force of gear 1 on
            #                                gear 2, along +y at (r1, 0)
            print(f" theta2 = {deg:3d} deg: theta3 = {s['th3']:.12f}, theta4 = "
                  f"{s['th4']:.12f} rad")
            print(f"   E = ({s['E'][0]:.12f}, {s['E'][1]:.12f})  P = ({s['P'][0]:.12f},"
                  f" {s['P'][1]:.12f})  Q = ({s['Q'][0]:.12f}, {s['Q'][1]:.12f}) m")
            print(f"   w3 = {s['w3']:.12f}, w4 = {s['w4']:.12f} rad/s;"
                  f" al3 = {s['al3']:.12f}, al4 = {s['al4']:.12f} rad/s^2")
            print(f"   vP = ({s['vP'][0]:.12f}, {s['vP'][1]:.12f}) m/s [fd {np.max(np.abs(fdv - s['vP'])):.1e}]"
                  f"  aP = ({s['aP'][0]:.12f}, {s['aP'][1]:.12f}) m/s^2 [fd {np.max(np.abs(fda - s['aP'])):.1e}]")
            print(f"   massless: tau2 = {tau2:.12f} N m, mesh tangential force "
                  f"f_t = {ft:.12f} N, |f| at 20 deg = {abs(ft) / math.cos(math.radians(20)):.12f} N"
                  f"  [power tau2 w2 + F.vP = {tau2 * w2 + F @ s['vP']:.1e}; fd Q {fdQ:.1e}]")


if __name__ == "__main__":
    main()
