#!/usr/bin/env python3
"""Draws the engines' force error against the time step, one line per stabilisation setting
(an SVG, log-log, each line's order of convergence in its legend), from the crank-rocker rows
(gravity on) of build/bench/force_accuracy --sweep's CSV.
Usage: scripts/plot_force_accuracy.py docs/data/engine-forces.csv docs/figures/force_error_vs_step.svg
"""
import re
import sys

from loglog import chart, read_rows


def series_name(engine, setting):
    """The stabilisation and read of a row's setting, without its step; None to leave it out."""
    s = re.sub(r";?\s*(max_step_angle|steps_per_sample) [0-9.e-]+", "", setting).strip("; ")
    if "split impulse" in s:
        return None  # identical to the same ERP without it (docs/engines-measured.md)
    if engine == "mujoco":
        if s in ("", "default"):
            return "MuJoCo, deadbeat solref, centred read (default)"
        if s in ("raw", "force_read raw"):
            return "MuJoCo, deadbeat solref, raw efc_force"
        if s.startswith("solref @"):  # a time constant of k steps, damping ratio 1
            return f"MuJoCo, solref ({s[8:-2]} dt, 1)"
        if s == "solref 0.02 1":
            return "MuJoCo, solref (0.02 s, 1): its default"
        return None  # solimp: within 10 % of the default (docs/engines-measured.md)
    if s in ("", "default"):
        return "Bullet, ERP 1, MLCP (default)"
    if s.startswith("erp"):
        return "Bullet, ERP " + s.split()[1] + ", MLCP"
    if s.startswith("sequential impulse"):
        return "Bullet, ERP 1, sequential impulse 100"
    return None


def main(src, dst, column="effort_pct"):
    series = {}
    for row in read_rows(src):
        if row["mechanism"] != "fourbar_crank_rocker" or row["gravity"] != "1":
            continue
        name = series_name(row["engine"], row["setting"])
        if name:
            point = (float(row["dt"]), float(row[column]))
            if point not in series.setdefault(name, []):
                series[name].append(point)
    label = {"effort_pct": "driver torque", "reaction_pct": "worst joint reaction"}[column]
    with open(dst, "w") as f:
        f.write(chart(series, "time step [s]", f"{label} error [% of peak]",
                      legend="{name}: order {slope:.2f}", width=900, legend_width=420))


if __name__ == "__main__":
    main(*sys.argv[1:])
