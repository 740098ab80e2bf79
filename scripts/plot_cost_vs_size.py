#!/usr/bin/env python3
"""Draws a log-log chart of cost against size (an SVG) from a CSV of method,bodies,cpu_seconds
rows, with each method's least-squares growth exponent in its legend.
Usage: scripts/plot_cost_vs_size.py docs/figures/a02_cost_vs_size.csv docs/figures/a02_cost_vs_size.svg
"""
import sys

from loglog import chart, read_rows


def main(src, dst):
    series = {}
    for row in read_rows(src):
        series.setdefault(row["method"], []).append((float(row["bodies"]), float(row["cpu_seconds"])))
    with open(dst, "w") as f:
        f.write(chart(series, "moving bodies", "CPU time of the 10 s run [s]",
                      legend="{name}: b^{slope:.2f}", width=640, legend_width=250))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
