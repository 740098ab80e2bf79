#!/usr/bin/env python3
"""The four engines side by side (docs/engines-measured.md, "Four engines side by side"), log-log SVGs.

forces: the driven crank-rocker's driver torque and worst pin force error against the time step
and against the CPU time per simulated second, each engine at its default stabilisation over
its step series (the crank-rocker rows with gravity of build/bench/force_accuracy --sweep
fourbar_crank_rocker). Simbody's time step is the spacing of the poses it reports (it steps to
each, max_step_angle, with its error-controlled Merson steps in between); the CPU axis puts the
four on one measure of what a setting costs.
  scripts/plot_engines.py forces docs/data/engine-forces-four.csv docs/figures/forces_four_engines

iftomm: the IFToMM error (the tip's largest position or velocity difference, m or m/s) against
the CPU time of the whole run, one line per engine variant over its time steps (Simbody: over
its accuracy settings), from `crosslink sweep --csv` files of one case; the two limits drawn.
  scripts/plot_engines.py iftomm docs/figures/iftomm_a02_engines.svg 10 docs/data/iftomm_a02_*.csv
"""
import math
import sys

from loglog import chart, read_rows

ENGINE = {"mujoco": "MuJoCo", "bullet": "Bullet", "ode": "ODE", "simbody": "Simbody"}
# Each engine's default stabilisation over its step (the bench's labels of those rows).
STEP_SERIES = {"mujoco": "max_step_angle", "bullet": "steps_per_sample", "ode": "steps_per_sample",
               "simbody": "max_step_angle"}


def forces(src, prefix, cycle=0.25):
    by_step, by_cpu = {}, {}
    for row in read_rows(src):
        if row["mechanism"] != "fourbar_crank_rocker" or row["gravity"] != "1":
            continue
        engine, setting = row["engine"], row["setting"]
        if setting != "default" and not setting.startswith(STEP_SERIES[engine] + " "):
            continue
        for column, what in (("effort_pct", "driver torque"), ("reaction_pct", "worst pin force")):
            y = float(row[column])
            if y <= 0:
                continue
            name = f"{ENGINE[engine]}, {what}"
            for series, x in ((by_step, float(row["dt"])),
                              (by_cpu, float(row["cpu_s_per_cycle"]) / cycle)):
                if (x, y) not in series.setdefault(name, []):
                    series[name].append((x, y))
    with open(prefix + "_vs_step.svg", "w") as f:
        f.write(chart(by_step, "time step [s] (Simbody: the spacing of its reported poses)",
                      "error [% of peak]", legend="{name}: order {slope:.2f}", width=900,
                      legend_width=330))
    with open(prefix + "_vs_cpu.svg", "w") as f:
        f.write(chart(by_cpu, "CPU time per simulated second [s]", "error [% of peak]",
                      legend="{name}: slope {slope:.2f}", width=900, legend_width=330))


def iftomm(dst, duration, *sources):
    series, xs = {}, []
    for i, src in enumerate(sources):
        for row in read_rows(src):
            if row["status"] != "ok":
                continue
            # The exact simulation's rows: from the first file only (every sweep has them).
            if row["engine"] == "analytic" and (i > 0 or "exact," not in row["variant"]):
                continue
            errors = [float(v) for v in (row["tip_position_error"], row["tip_velocity_error"]) if v]
            if not errors or not row["cpu_s_per_cycle"] or max(errors) <= 0:
                continue
            x = float(row["cpu_s_per_cycle"]) * float(duration)
            name = (f"{ENGINE[row['engine']]} {row['variant']}" if row["engine"] in ENGINE
                    else "exact simulation, dopri5 over its tolerance")
            if name.startswith("Simbody Merson accuracy"):  # one line over its error control
                name = "Simbody Merson over its accuracy (1e-6, 1e-8, 1e-10)"
            series.setdefault(name, []).append((x, max(errors)))
            xs.append(x)
    lo, hi = min(xs), max(xs)
    for limit in (1e-1, 1e-3):
        series[f"IFToMM limit {limit:g}"] = [(lo, limit), (hi, limit)]
    with open(dst, "w") as f:
        f.write(chart(series, "CPU time of the whole run [s]",
                      "IFToMM error: tip position [m] or velocity [m/s]",
                      legend="{name}", width=1000, legend_width=430))


if __name__ == "__main__":
    {"forces": forces, "iftomm": iftomm}[sys.argv[1]](*sys.argv[2:])
