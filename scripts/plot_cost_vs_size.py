#!/usr/bin/env python3
"""Draws a log-log chart of cost against size (an SVG, no plotting library needed) from a CSV of
method,bodies,cpu_seconds rows, with each method's least-squares growth exponent in its legend.
Usage: scripts/plot_cost_vs_size.py docs/figures/a02_cost_vs_size.csv docs/figures/a02_cost_vs_size.svg
"""
import csv
import math
import sys

COLOURS = {"reference": "#222222", "MuJoCo": "#1f77b4", "Bullet": "#d62728"}  # as the reports


def slope(points):
    xs = [math.log(b) for b, _ in points]
    ys = [math.log(c) for _, c in points]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)


def main(src, dst):
    series = {}
    with open(src) as f:
        for row in csv.DictReader(line for line in f if not line.startswith("#")):
            series.setdefault(row["method"], []).append((float(row["bodies"]), float(row["cpu_seconds"])))
    w, h, left, right, top, bottom = 640, 360, 70, 250, 20, 50
    bodies = [b for s in series.values() for b, _ in s]
    costs = [c for s in series.values() for _, c in s]
    x0, x1 = math.floor(math.log10(min(bodies))), math.ceil(math.log10(max(bodies)))
    y0, y1 = math.floor(math.log10(min(costs))), math.ceil(math.log10(max(costs)))
    X = lambda b: left + (math.log10(b) - x0) / (x1 - x0) * (w - left - right)
    Y = lambda c: h - bottom - (math.log10(c) - y0) / (y1 - y0) * (h - top - bottom)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="11">',
           f'<rect x="{left}" y="{top}" width="{w - left - right}" height="{h - top - bottom}" fill="none" stroke="#888"/>']
    for e in range(x0, x1 + 1):
        for m in (1, 2, 5):
            b = m * 10 ** e
            if x0 <= math.log10(b) <= x1:
                out.append(f'<line x1="{X(b):.1f}" y1="{top}" x2="{X(b):.1f}" y2="{h - bottom}" stroke="#eee"/>')
                out.append(f'<text x="{X(b):.1f}" y="{h - bottom + 14}" text-anchor="middle">{b:g}</text>')
    for e in range(y0, y1 + 1):
        out.append(f'<line x1="{left}" y1="{Y(10 ** e):.1f}" x2="{w - right}" y2="{Y(10 ** e):.1f}" stroke="#eee"/>')
        out.append(f'<text x="{left - 6}" y="{Y(10 ** e) + 4:.1f}" text-anchor="end">{10 ** e:g}</text>')
    out.append(f'<text x="{(left + w - right) / 2}" y="{h - 12}" text-anchor="middle">moving bodies</text>')
    out.append(f'<text transform="translate(16,{(top + h - bottom) / 2}) rotate(-90)" text-anchor="middle">CPU time of the 10 s run [s]</text>')
    for i, (name, pts) in enumerate(series.items()):
        colour = next((c for k, c in COLOURS.items() if name.startswith(k)), "#555")
        pts.sort()
        path = " ".join(f"{X(b):.1f},{Y(c):.1f}" for b, c in pts)
        out.append(f'<polyline points="{path}" fill="none" stroke="{colour}" stroke-width="1.8"/>')
        out += [f'<circle cx="{X(b):.1f}" cy="{Y(c):.1f}" r="3" fill="{colour}"/>' for b, c in pts]
        ly = top + 16 + 18 * i
        out.append(f'<line x1="{w - right + 12}" y1="{ly - 4}" x2="{w - right + 32}" y2="{ly - 4}" stroke="{colour}" stroke-width="1.8"/>')
        out.append(f'<text x="{w - right + 38}" y="{ly}">{name}: b^{slope(pts):.2f}</text>')
    out.append("</svg>")
    with open(dst, "w") as f:
        f.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
