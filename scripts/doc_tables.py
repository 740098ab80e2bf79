#!/usr/bin/env python3
"""Renders the measurement tables of docs/engines-measured.md from the CSVs in docs/data/ that
the benches and scripts write, so that a table cannot drift from its measurement.

Each table sits in the document between
    <!-- generated: scripts/doc_tables.py NAME (from docs/data/FILE.csv) -->
    <!-- end generated -->
under one line naming the command that remeasures its CSV.
    scripts/doc_tables.py --write    rewrites every block from its CSV
    scripts/doc_tables.py --check    exits 1 naming each block that is stale, missing or whose
                                     CSV is missing (ctest docs.measured_tables_current)
Run from the source root. Standard library only.
"""
import csv
import re
import sys
from decimal import ROUND_HALF_UP, Decimal
from pathlib import Path

DOC = Path("docs/engines-measured.md")

FORCES = "build/bench/force_accuracy --sweep > docs/data/engine-forces.csv"
FORCES_FOUR = ("build/bench/force_accuracy --sweep fourbar_crank_rocker > "
               "docs/data/engine-forces-four.csv")
GEARS = "build/bench/gear_accuracy > docs/data/gear_accuracy.csv"
IFTOMM = "scripts/measure_iftomm_engines.sh"

# The IFToMM tables' rows: label, engine, its default variant, and what its setting is along its
# line (the step; the exact simulation's tolerance; Simbody: its accuracy, at one report spacing).
IFTOMM_ROWS = [
    ("exact simulation (dopri5)", "analytic", "exact, tolerance", "tolerance"),
    ("MuJoCo Euler/Newton", "mujoco", "Euler/Newton", "step"),
    ("Bullet rigid/MLCP ERP 1", "bullet", "rigid/MLCP Dantzig erp 1", "step"),
    ("ODE `dWorldStep` ERP 1 CFM 1e-10", "ode", "dWorldStep erp 1 cfm 1e-10", "step"),
    ("Simbody Merson 1e-8", "simbody", "Merson accuracy 1e-8", "accuracy"),
]


def iftomm_columns(duration):
    """duration [s]: the CSV's CPU per simulated second to the CPU of the whole run."""
    return [("engine", lambda k, d: k[0])] + [
        (f"default, limit {text}", lambda k, d, limit=Decimal(text): iftomm_default(d, k, limit))
        for text in ("1e-1", "1e-3")] + [
        (f"cheapest to {text}",
         lambda k, d, limit=Decimal(text): iftomm_cheapest(d, k, limit, duration))
        for text in ("1e-1", "1e-3")]


# The tables. Each names its CSVs, the command that writes them, its rows (keys, or a function
# of the CSV rows giving the keys) and its columns: (header, cell), where cell(key, rows) is the
# cell's text, number formats included (num() below). Lambdas, so that the helpers they call can
# follow.
TABLES = [
    {   # "Forces", "Measured at the defaults": the worse of without and with gravity.
        "name": "forces_defaults", "csv": ["docs/data/engine-forces.csv"], "command": FORCES,
        "rows": lambda d: unique(r["mechanism"] for r in d if r["setting"] == "default"),
        "columns": [
            ("mechanism", lambda m, d: definition(m)),
            ("MuJoCo effort / reaction / shaking", lambda m, d: worst3(d, "mujoco", m)),
            ("s", lambda m, d: places(worst(d, "mujoco", m, "s_per_cycle"), 3)),
            ("Bullet effort / reaction / shaking", lambda m, d: worst3(d, "bullet", m)),
            ("s", lambda m, d: places(worst(d, "bullet", m, "s_per_cycle"), 3)),
        ]},
    {   # "Force error against stabilisation and step": the crank-rocker's step series side by side.
        "name": "forces_step", "csv": ["docs/data/engine-forces.csv"], "command": FORCES,
        "rows": lambda d: range(max(len(step_series(d, s)) for s in STEP_SERIES)),
        "columns": [
            ("MuJoCo dt [s]", lambda i, d: step_cell(d, "centred", i, dt=True)),
            ("centred (default)", lambda i, d: step_cell(d, "centred", i)),
            ("raw efc_force", lambda i, d: step_cell(d, "raw", i)),
            ("Bullet dt [s]", lambda i, d: step_cell(d, "bullet", i, dt=True)),
            ("ERP 1 (default)", lambda i, d: step_cell(d, "bullet", i)),
        ]},
    {   # "Stabilisation at the default step": MuJoCo's and Bullet's settings side by side.
        "name": "forces_stabilisation", "csv": ["docs/data/engine-forces.csv"], "command": FORCES,
        "rows": [  # MuJoCo's label and setting; Bullet's label and its settings at 2 and 8 steps
            ("solref deadbeat (default)", "default", "ERP 1 (default)", "default", "steps_per_sample 8"),
            ("solref (2 dt, 1)", "solref @2dt", "ERP 0.95", "erp 0.95; steps_per_sample 2", "erp 0.95; steps_per_sample 8"),
            ("solref (4 dt, 1)", "solref @4dt", "ERP 0.8", "erp 0.8; steps_per_sample 2", "erp 0.8; steps_per_sample 8"),
            ("solref 0.02 1 (MuJoCo's default)", "solref 0.02 1", "ERP 0.5", "erp 0.5; steps_per_sample 2", "erp 0.5; steps_per_sample 8"),
            ("solimp 0.99", "solimp 0.99 0.99 0.001", "ERP 0.2", "erp 0.2; steps_per_sample 2", "erp 0.2; steps_per_sample 8"),
            ("solimp 0.999", "solimp 0.999 0.999 0.001", "split impulse (any ERP)", None, None),
            ("solimp 0.99999", "solimp 0.99999 0.99999 0.001", "sequential impulse, 100 iterations",
             "sequential impulse 100; steps_per_sample 2", "sequential impulse 100; steps_per_sample 8"),
        ],
        "columns": [
            ("MuJoCo", lambda k, d: k[0]),
            ("effort / reaction", lambda k, d: stabilisation_cell(d, "mujoco", k[1])),
            ("Bullet (2 / 8 steps per sample)", lambda k, d: k[2]),
            ("effort / reaction", lambda k, d: split_impulse_cell(d) if k[3] is None
             else "; ".join(stabilisation_cell(d, "bullet", s) for s in k[3:])),
        ]},
    {   # "Four engines side by side", driver torque and pin forces against the step.
        "name": "forces_four", "csv": ["docs/data/engine-forces-four.csv"], "command": FORCES_FOUR,
        "rows": [("mujoco", "MuJoCo Euler, dt"), ("bullet", "Bullet rigid MLCP ERP 1, dt"),
                 ("ode", "ODE `dWorldStep` ERP 1"), ("simbody", "Simbody Merson 1e-8, reports every")],
        "columns": [
            ("engine, its step", lambda k, d: four_steps(d, *k)),
            ("driver torque / worst pin force", lambda k, d: four_errors(d, k[0])),
            ("CPU per simulated s", lambda k, d: " / ".join(
                num(Decimal(r["cpu_s_per_cycle"]) / CRANK_ROCKER_CYCLE)
                for r in four_series(d, k[0])) + " s"),
        ]},
    {   # "Gear couplings: drift and mesh force against the step".
        "name": "gear_accuracy", "csv": ["docs/data/gear_accuracy.csv"], "command": GEARS,
        "rows": [  # engine label, definition label, engine, mechanism, its gearings
            ("MuJoCo", "geared five-bar, mesh", "mujoco", "geared_fivebar", ["mesh"]),
            ("MuJoCo", "planetary, sun-planet", "mujoco", "planetary_fixed_ring", ["sun_planet"]),
            ("MuJoCo", "planetary, planet-ring", "mujoco", "planetary_fixed_ring", ["planet_ring"]),
            ("MuJoCo", "rack and pinion", "mujoco", "rack_pinion_slider_crank", ["mesh"]),
            ("Simbody", "geared five-bar", "simbody", "geared_fivebar", ["mesh"]),
            ("Simbody", "planetary, sun-planet / planet-ring", "simbody", "planetary_fixed_ring", ["sun_planet", "planet_ring"]),
            ("Simbody", "rack and pinion", "simbody", "rack_pinion_slider_crank", ["mesh"]),
            ("Bullet (rigid)", "geared five-bar", "bullet", "geared_fivebar", ["mesh"]),
            ("Bullet (rigid)", "Constans & Dyer's geared five-bar", "bullet", "constans_dyer_geared_fivebar", ["mesh"]),
            ("Bullet (rigid, recombined)", "planetary, sun-planet / planet-ring", "bullet", "planetary_fixed_ring", ["sun_planet", "planet_ring"]),
            ("Bullet (rigid, recombined)", "epicyclic 72/32, sun-planet / planet-ring", "bullet", "epicyclic_ring72_sun32", ["sun_planet", "planet_ring"]),
            ("ODE", "geared five-bar", "ode", "geared_fivebar", ["mesh"]),
            ("ODE", "Constans & Dyer's geared five-bar", "ode", "constans_dyer_geared_fivebar", ["mesh"]),
            ("Bullet (multibody)", "rack-and-pinion slider-crank", "bullet", "rack_pinion_slider_crank", ["mesh"]),
            ("Bullet (multibody)", "Ryan's rack and pinion", "bullet", "ryan_rack_and_pinion", ["mesh"]),
        ],
        "columns": [
            ("engine", lambda k, d: k[0]),
            ("definition, gearing", lambda k, d: k[1]),
            ("max_step_angle 0.02: drift, mesh", lambda k, d: gear_cell(d, k, "0.02", first=True)),
            ("0.005", lambda k, d: gear_cell(d, k, "0.005")),
            ("0.0025 (default)", lambda k, d: gear_cell(d, k, "0.0025")),
            ("0.000625", lambda k, d: gear_cell(d, k, "0.000625")),
        ]},
    {   # "IFToMM A01, A02 and A03": A02, N = 2 over 10 s; A03, Andrews' squeezer over 0.03 s.
        "name": "iftomm_a02", "csv": ["docs/data/iftomm_a02_engines.csv", "docs/data/iftomm_a02_simbody.csv"],
        "command": IFTOMM, "rows": IFTOMM_ROWS, "columns": iftomm_columns(duration=Decimal(10))},
    {   "name": "iftomm_a03", "csv": ["docs/data/iftomm_a03_engines.csv", "docs/data/iftomm_a03_simbody.csv"],
        "command": IFTOMM, "rows": IFTOMM_ROWS, "columns": iftomm_columns(duration=Decimal("0.03"))},
]

# --- number formats -------------------------------------------------------------------------


def num(value, digits=2, sci_below=0, strip=False):
    """value (a CSV string or a Decimal) to `digits` significant digits, rounded half up on the
    decimal the CSV holds (not on its binary double, which turns 0.000165 into 0.00016); a value
    with more integer digits keeps them (541, not 540); below sci_below as 6.6e-4; strip drops
    trailing zeros (0.04, not 0.040)."""
    d = Decimal(str(value))
    if d == 0:
        return "0"
    if abs(d) >= 10 ** digits:
        return str(d.quantize(Decimal(1), ROUND_HALF_UP))
    r = d.quantize(Decimal(1).scaleb(d.adjusted() - digits + 1), ROUND_HALF_UP)
    if r.adjusted() > d.adjusted():  # rounded up a decade (0.000996 -> 0.00100): one digit less
        r = r.quantize(Decimal(1).scaleb(r.adjusted() - digits + 1), ROUND_HALF_UP)
    if abs(d) < sci_below:
        text, exponent = format(r.scaleb(-r.adjusted()), "f"), f"e{r.adjusted()}"
    else:
        text, exponent = format(r, "f"), ""
    if strip and "." in text:
        text = text.rstrip("0").rstrip(".")
    return text + exponent


def places(value, n):
    """A time in s to n decimal places: 0.008."""
    return str(Decimal(str(value)).quantize(Decimal(1).scaleb(-n), ROUND_HALF_UP))


def sci(value, strip=False):
    """A step or a drift: 3.5e-4 (5e-4 with strip)."""
    return num(value, sci_below=Decimal("1e300"), strip=strip)


def small(value):
    """An error in % of peak: 0.043, below 1e-3 as 6.6e-4."""
    return num(value, sci_below=Decimal("1e-3"))


# --- selections and cells -------------------------------------------------------------------


def unique(items):
    return list(dict.fromkeys(items))


def where(rows, **match):
    return [r for r in rows if all(r[k] == v for k, v in match.items())]


def one(rows, **match):
    found = where(rows, **match)
    if len(found) != 1:
        raise LookupError(f"{len(found)} rows with {match}, not 1")
    return found[0]


def definition(mechanism):
    """The path of a bundled definition under mechanisms/, as the tables name them."""
    published = Path(f"mechanisms/published/{mechanism}.toml").exists()
    return f"published/{mechanism}" if published else mechanism


def worst(rows, engine, mechanism, column):
    """The worse of the definition without and with gravity."""
    runs = where(rows, engine=engine, mechanism=mechanism, setting="default")
    return max(Decimal(r[column]) for r in runs)


def worst3(rows, engine, mechanism):
    return " / ".join(num(worst(rows, engine, mechanism, c), strip=True)
                      for c in ("effort_pct", "reaction_pct", "shaking_pct"))


def pair(row):
    return f"{num(row['effort_pct'])} / {num(row['reaction_pct'])}"


# The crank-rocker's step series under gravity (the sweep's rows), by the setting's pattern.
STEP_SERIES = {"centred": ("mujoco", r"default|max_step_angle \S+"),
               "raw": ("mujoco", r"force_read raw|raw; max_step_angle \S+"),
               "bullet": ("bullet", r"steps_per_sample \S+")}


def step_series(rows, series):
    engine, pattern = STEP_SERIES[series]
    found = [r for r in where(rows, engine=engine, mechanism="fourbar_crank_rocker", gravity="1")
             if re.fullmatch(pattern, r["setting"])]
    return sorted(found, key=lambda r: -float(r["dt"]))


def step_cell(rows, series, i, dt=False):
    found = step_series(rows, series)
    if i >= len(found):
        return ""
    r = found[i]
    if dt:
        return sci(r["dt"]) + (" (default)" if r["setting"] == "default" else "")
    return pair(r)


def stabilisation_cell(rows, engine, setting):
    r = one(rows, engine=engine, mechanism="fourbar_crank_rocker", gravity="1", setting=setting)
    return pair(r) + (" (lost the driver)" if r["note"] == "not ok" else "")


def split_impulse_cell(rows):
    """Bullet's split impulse against the same ERP without it, every ERP and step."""
    crank = where(rows, engine="bullet", mechanism="fourbar_crank_rocker", gravity="1")
    split = [r for r in crank if "split impulse" in r["setting"]]
    same = all(pair(r) == pair(one(crank, setting=r["setting"].replace(" split impulse", "")))
               for r in split)
    return "identical to without" if split and same else "not identical to without (the CSV)"


CRANK_ROCKER_CYCLE = Decimal("0.25")  # s: CPU per cycle to CPU per simulated second
# Each engine's default stabilisation over its step (as scripts/plot_engines.py draws it);
# Bullet's and ODE's "steps_per_sample 1" is their default's step, run again.
FOUR_SERIES = {"mujoco": "max_step_angle", "bullet": "steps_per_sample", "ode": "steps_per_sample",
               "simbody": "max_step_angle"}


def four_series(rows, engine):
    found = [r for r in where(rows, engine=engine, mechanism="fourbar_crank_rocker", gravity="1")
             if r["setting"] == "default" or (r["setting"].startswith(FOUR_SERIES[engine] + " ")
                                              and r["setting"] != "steps_per_sample 1")]
    return sorted(found, key=lambda r: -float(r["dt"]))


def four_steps(rows, engine, label):
    steps = [sci(r["dt"]) + (" (default)" if r["setting"] == "default" else "")
             for r in four_series(rows, engine)]
    same = [r["dt"] for r in four_series(rows, "ode")] == [r["dt"] for r in four_series(rows, "bullet")]
    if engine == "ode" and same:
        return f"{label}, the same steps"
    return f"{label} {' / '.join(steps)} s"


def four_errors(rows, engine):
    series = four_series(rows, engine)
    if engine == "ode":  # the same discretisation as Bullet's rigid bodies: said when it is
        errors = lambda rs: [(r["effort_pct"], r["reaction_pct"]) for r in rs]
        if errors(series) == errors(four_series(rows, "bullet")):  # the CSV's 3 digits
            return "the same to 3 digits"
    return "; ".join(" / ".join(small(r[c]) for r in series) for c in ("effort_pct", "reaction_pct"))


def gear_cell(rows, key, angle, first=False):
    """Drift (rad, a rack's m) and mesh force (% of peak) of each gearing at one max_step_angle."""
    _, _, engine, mechanism, gearings = key
    found = [one(rows, engine=engine, mechanism=mechanism, gearing=g, max_step_angle=angle)
             for g in gearings]
    unit = found[0]["drift_unit"]
    drift = " / ".join(sci(r["drift"]) for r in found)
    if not found[0]["mesh_pct"]:
        text = f"{drift} {unit}" + (", forces not read" if first else "")
    else:
        mesh = " / ".join(small(r["mesh_pct"]) for r in found)
        text = f"{drift} {unit}, {mesh} %" if first else f"{drift}, {mesh} %"
    if first:  # a step capped by the engine is the next one's: said, not shown as a measurement
        coarse = one(rows, engine=engine, mechanism=mechanism, gearing=gearings[0],
                     max_step_angle="0.01")
        if coarse["dt"] == found[0]["dt"]:
            text += f" (its step is capped at {sci(found[0]['dt'])} s: the same as 0.01)"
    return text


def iftomm_error(row):
    """The IFToMM measure: the tip's worst position [m] or velocity [m/s] difference."""
    errors = [Decimal(v) for v in (row["tip_position_error"], row["tip_velocity_error"]) if v]
    return max(errors) if errors and row["status"] == "ok" else None


def iftomm_rows(rows, engine):
    # The exact simulation's rows are in every sweep's CSV: the first file's (as the figures).
    return [r for r in rows if r["engine"] == engine and (engine != "analytic" or r["_file"] == 0)]


def is_default(row, default, kind):
    # The exact simulation's default is its whole tolerance series; an engine's, one variant.
    return row["variant"].startswith(default) if kind == "tolerance" else row["variant"] == default


def knob(row, kind):
    """What a row's setting is along its engine's line: the step, or the exact simulation's
    tolerance (the largest first); Simbody runs at one report spacing."""
    if kind == "tolerance":
        return Decimal(row["variant"].rsplit(" ", 1)[1])
    return Decimal(row["dt"])


def iftomm_default(rows, key, limit):
    """The default's coarsest setting meeting the limit, or never and its best."""
    _, engine, default, kind = key
    runs = [r for r in iftomm_rows(rows, engine) if is_default(r, default, kind)]
    met = [r for r in runs if iftomm_error(r) is not None and iftomm_error(r) <= limit]
    if met:
        r = max(met, key=lambda r: knob(r, kind))
        if kind == "accuracy":
            setting = "meets it"
        elif kind == "tolerance":
            setting = f"tolerance {sci(knob(r, kind), strip=True)}"
        else:
            setting = f"{sci(r['dt'], strip=True)} s"
        return f"{setting}: {small(iftomm_error(r))}"
    usable = [r for r in runs if iftomm_error(r) is not None]
    if not usable:  # every run stopped: the first run's reason
        return "never: " + runs[0]["message"].split(":")[0]
    best = min(usable, key=iftomm_error)
    at = f" at {sci(best['dt'], strip=True)} s" if kind == "step" else ""
    return f"never: {small(iftomm_error(best))}{at}"


def iftomm_cheapest(rows, key, limit, duration):
    """The cheapest of the engine's variants meeting the limit (CPU of the whole run)."""
    _, engine, default, kind = key
    runs = [r for r in iftomm_rows(rows, engine) if iftomm_error(r) is not None]
    met = [r for r in runs if iftomm_error(r) <= limit]
    if not met:
        best = min(runs, key=iftomm_error)
        return f"never: best {best['variant']}, {small(iftomm_error(best))}"
    cpu = lambda r: num(Decimal(r["cpu_s_per_cycle"]) * duration) + " s"
    r = min(met, key=lambda r: Decimal(r["cpu_s_per_cycle"]))
    name = "the default" if is_default(r, default, kind) else r["variant"]
    if kind == "tolerance":
        return f"tolerance {sci(knob(r, kind), strip=True)}, {cpu(r)}"
    if kind == "accuracy":
        return f"{name}: {small(iftomm_error(r))}, {cpu(r)}"
    text = f"{name} at {sci(r['dt'], strip=True)} s, {cpu(r)}"
    defaults = [d for d in met if is_default(d, default, kind)]
    if not is_default(r, default, kind) and defaults:  # what the default costs to the same limit
        text += f" (the default {cpu(max(defaults, key=lambda d: Decimal(d['dt'])))})"
    return text


# --- rendering and the document ------------------------------------------------------------


def load(table):
    rows = []
    for i, path in enumerate(table["csv"]):
        with open(path, newline="") as f:
            rows += [dict(r, _file=i) for r in csv.DictReader(f)]
    return rows


def render(table):
    """The block: the command line, the markers and the markdown table."""
    rows = load(table)
    keys = table["rows"](rows) if callable(table["rows"]) else table["rows"]
    lines = ["| " + " | ".join(h for h, _ in table["columns"]) + " |",
             "|" + "---|" * len(table["columns"])]
    for key in keys:
        lines.append("| " + " | ".join(cell(key, rows) for _, cell in table["columns"]) + " |")
    csvs = ", ".join(table["csv"])
    return "\n".join([
        f"Measured by `{table['command']}`; table rendered from {csvs} by "
        "`scripts/doc_tables.py --write`:",
        f"<!-- generated: scripts/doc_tables.py {table['name']} (from {csvs}) -->",
        *lines,
        "<!-- end generated -->"])


def block_pattern(name):
    # The command line above the block is part of it (rewritten with it).
    return re.compile(r"^(?:Measured by `[^\n]*`; table rendered from [^\n]*\n)?"
                      rf"<!-- generated: scripts/doc_tables\.py {re.escape(name)} \("
                      r".*?<!-- end generated -->", re.M | re.S)


def main(mode):
    doc = DOC.read_text()
    problems = []
    for table in TABLES:
        found = block_pattern(table["name"]).search(doc)
        if not found:
            problems.append(f"{table['name']}: no generated block in {DOC}")
            continue
        missing = [p for p in table["csv"] if not Path(p).exists()]
        if missing:
            problems.append(f"{table['name']}: missing {', '.join(missing)}")
            continue
        try:
            block = render(table)
        except (LookupError, ValueError, ArithmeticError) as e:  # the CSV no longer has its rows
            problems.append(f"{table['name']}: cannot render from {', '.join(table['csv'])}: {e!r}")
            continue
        if found.group(0) != block:
            if mode == "--write":
                doc = doc[:found.start()] + block + doc[found.end():]
            else:
                problems.append(f"{table['name']}: stale, differs from what {', '.join(table['csv'])} "
                                f"renders (scripts/doc_tables.py --write)")
    names = {t["name"] for t in TABLES}
    for name in re.findall(r"<!-- generated: scripts/doc_tables\.py (\S+)", doc):
        if name not in names:
            problems.append(f"{name}: a generated block no table of scripts/doc_tables.py renders")
    if mode == "--write":
        DOC.write_text(doc)
    for p in problems:
        print(p)
    return 1 if problems else 0


if __name__ == "__main__":
    if len(sys.argv) != 2 or sys.argv[1] not in ("--write", "--check"):
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1]))
