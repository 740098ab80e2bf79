"""A log-log line chart as an SVG (no plotting library needed), for the figures in docs/.

chart(series, x_label, y_label) takes {name: [(x, y), ...]} and returns the SVG text; each
series' least-squares slope of log y against log x (its growth exponent, or its order of
convergence) is written in the legend, where it has two points or more.
"""
import csv
import math

# The reports' colours: the reference black, MuJoCo blue, Bullet red, ODE green, Simbody purple;
# each engine's variants get their own dash and marker.
BASE = {"reference": "#222222", "MuJoCo": "#1f77b4", "Bullet": "#d62728", "ODE": "#2ca02c",
        "Simbody": "#9467bd"}
DASHES = ["", "6,3", "2,2", "8,3,2,3", "1,3", "10,4"]
MARKERS = ["circle", "square", "triangle", "diamond", "cross", "plus"]


def marker(kind, x, y, colour):
    if kind == "circle":
        return f'<circle cx="{x:.1f}" cy="{y:.1f}" r="3" fill="{colour}"/>'
    shape = {"square": [(-3, -3), (3, -3), (3, 3), (-3, 3)], "triangle": [(0, -4), (4, 3), (-4, 3)],
             "diamond": [(0, -4), (4, 0), (0, 4), (-4, 0)],
             "cross": [(-4, -3), (-3, -4), (0, -1), (3, -4), (4, -3), (1, 0), (4, 3), (3, 4), (0, 1), (-3, 4), (-4, 3), (-1, 0)],
             "plus": [(-1, -4), (1, -4), (1, -1), (4, -1), (4, 1), (1, 1), (1, 4), (-1, 4), (-1, 1), (-4, 1), (-4, -1), (-1, -1)]}[kind]
    points = " ".join(f"{x + dx:.1f},{y + dy:.1f}" for dx, dy in shape)
    return f'<polygon points="{points}" fill="{colour}"/>'


def slope(points):
    xs = [math.log(x) for x, _ in points]
    ys = [math.log(y) for _, y in points]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    spread = sum((x - mx) ** 2 for x in xs)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / spread if spread else math.nan


def chart(series, x_label, y_label, legend="{name}: slope {slope:.2f}", width=720, legend_width=290):
    """legend formats a series' legend entry from its name and slope (where it has one)."""
    h = max(360, 60 + 18 * len(series))
    w, left, right, top, bottom = width, 70, legend_width, 20, 50
    xs = [x for s in series.values() for x, _ in s]
    ys = [y for s in series.values() for _, y in s]
    x0, x1 = math.floor(math.log10(min(xs))), math.ceil(math.log10(max(xs)))
    y0, y1 = math.floor(math.log10(min(ys))), math.ceil(math.log10(max(ys)))
    X = lambda x: left + (math.log10(x) - x0) / (x1 - x0) * (w - left - right)
    Y = lambda y: h - bottom - (math.log10(y) - y0) / (y1 - y0) * (h - top - bottom)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="11">',
           f'<rect x="{left}" y="{top}" width="{w - left - right}" height="{h - top - bottom}" fill="none" stroke="#888"/>']
    for e in range(x0, x1 + 1):
        for m in (1, 2, 5):
            x = m * 10 ** e
            if x0 <= math.log10(x) <= x1:
                out.append(f'<line x1="{X(x):.1f}" y1="{top}" x2="{X(x):.1f}" y2="{h - bottom}" stroke="#eee"/>')
                out.append(f'<text x="{X(x):.1f}" y="{h - bottom + 14}" text-anchor="middle">{x:g}</text>')
    step = max(1, (y1 - y0) // 8)
    for e in range(y0, y1 + 1, step):
        out.append(f'<line x1="{left}" y1="{Y(10 ** e):.1f}" x2="{w - right}" y2="{Y(10 ** e):.1f}" stroke="#eee"/>')
        out.append(f'<text x="{left - 6}" y="{Y(10 ** e) + 4:.1f}" text-anchor="end">{10 ** e:g}</text>')
    out.append(f'<text x="{(left + w - right) / 2}" y="{h - 12}" text-anchor="middle">{x_label}</text>')
    out.append(f'<text transform="translate(16,{(top + h - bottom) / 2}) rotate(-90)" text-anchor="middle">{y_label}</text>')
    used = {}
    for i, (name, pts) in enumerate(series.items()):
        base = next((k for k in BASE if name.startswith(k)), None)
        colour = BASE.get(base, "#555")
        k = used.get(base, 0)
        dash, kind = DASHES[k % len(DASHES)], MARKERS[k % len(MARKERS)]
        used[base] = k + 1
        pts = sorted(pts)
        style = f'stroke="{colour}" stroke-width="1.8"' + (f' stroke-dasharray="{dash}"' if dash else "")
        if len(pts) > 1:
            path = " ".join(f"{X(x):.1f},{Y(y):.1f}" for x, y in pts)
            out.append(f'<polyline points="{path}" fill="none" {style}/>')
        out += [marker(kind, X(x), Y(y), colour) for x, y in pts]
        ly = top + 16 + 18 * i
        out.append(f'<line x1="{w - right + 12}" y1="{ly - 4}" x2="{w - right + 32}" y2="{ly - 4}" {style}/>')
        out.append(marker(kind, w - right + 22, ly - 4, colour))
        label = legend.format(name=name, slope=slope(pts)) if len(pts) > 1 else name
        out.append(f'<text x="{w - right + 38}" y="{ly}">{label}</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n"


def read_rows(path):
    """The rows of a CSV whose leading '#' lines are comments."""
    with open(path) as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))
