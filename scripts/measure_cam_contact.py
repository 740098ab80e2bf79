#!/usr/bin/env python3
"""The engines' cam contact against the exact reference (docs/engines.md, "Cams"): per bundled
definition an engine holds by contact and per engine setting, the worst % of peak of the
follower's travel, acceleration and contact force, the deepest penetration over the samples
(from the engine's own positions: the roller's centre C's distance from the disc's centre X short
of R + r; or the flat face's height above the disc's centre short of R), and the jump speed read
from the engine's own contact force at the jump's pose at two speeds below it (N = a - b w^2 at a
pose: the speed where it is zero), beside the exact force's from the same two speeds.
Usage: measure_cam_contact.py CROSSLINK   (prints a Markdown table)"""
import csv, json, math, subprocess, sys, tempfile
from pathlib import Path

cl = sys.argv[1]


def roller_depth(v, i):  # eccentric_roller_spring: R + r = 0.12 m
    return 0.12 - math.hypot(v[("x.C", i)] - v[("x.X", i)], v[("y.C", i)] - v[("y.X", i)])


def face_depth(v, i):  # eccentric_flat_faced: the disc's centre at (e sin t, -e cos t), R = 0.04
    return 0.04 - (v[("y.F", i)] + 0.01 * math.cos(v[("angle.cam", i)]))


# (engine, definition, its speed [rpm], two speeds below the jump, the jump's sample, depth,
# settings)
CASES = [
    ("mujoco", "eccentric_roller_spring", 240, (200, 240), 0, roller_depth,
     [[], ["dt=2e-4"], ["dt=5e-5"], ["contact_solimp=0.4 0.4 0.001"],
      ["contact_solimp=0.6 0.6 0.001"], ["contact_solimp=0.9 0.95 0.001"],
      ["contact_solimp=0.9999 0.9999 0.001"], ["contact_solref=0.001 1"]]),
    ("mujoco", "eccentric_flat_faced", 600, (500, 600), 180, face_depth,
     [[], ["dt=8e-5"], ["contact_solimp=0.9 0.95 0.001"]]),
    ("ode", "eccentric_roller_spring", 240, (200, 240), 0, roller_depth,
     [[], ["steps_per_sample=4"], ["steps_per_sample=8"],
      ["contact_erp=0.2", "contact_cfm=1e-3"]]),
    ("ode", "eccentric_flat_faced", 600, (500, 600), 180, face_depth,
     [[], ["steps_per_sample=4"]]),
    ("bullet", "eccentric_roller_spring", 240, (200, 240), 0, roller_depth,
     [[], ["steps_per_sample=4"], ["solver=sequential_impulse"]]),
    ("bullet", "eccentric_flat_faced", 600, (500, 600), 180, face_depth, [[]]),
    ("simbody", "eccentric_roller_spring", 240, (200, 240), 0, roller_depth,
     [[], ["contact_stiffness=2e12"], ["contact_stiffness=2e10"], ["contact_dissipation=100"],
      ["contact_dissipation=1"]]),
    ("simbody", "eccentric_flat_faced", 600, (500, 600), 180, face_depth,
     [[], ["contact_stiffness=2e12"]]),
]


def run(engine, name, speed, rpm, settings, folder):
    text = Path(f"mechanisms/cams/{name}.toml").read_text()
    text = text.replace(f"\nspeed = {speed} ", f"\nspeed = {rpm} ").replace(
        f"\nspeed = {speed}\n", f"\nspeed = {rpm}\n")
    toml = folder / f"{name}_{rpm}.toml"
    toml.write_text(text)
    out_csv, out_json = folder / "run.csv", folder / "run.json"
    args = [cl, "compare", str(toml), "--engines", engine, "--csv", str(out_csv),
            "--json", str(out_json)]
    for s in settings:
        args += ["--set", f"{engine}:{s}"]
    subprocess.run(args, capture_output=True, check=False)
    doc = json.loads(out_json.read_text())
    worst = {c["channel"]: c["max_pct_of_peak"] for c in doc["channels"] if c["method"] == engine}
    values, exact = {}, {}
    for row in csv.DictReader(out_csv.open()):
        if row["method"] == engine and row["sample"] and row["value"] and row["reference"]:
            values[(row["channel"], int(row["sample"]))] = float(row["value"])
            exact[(row["channel"], int(row["sample"]))] = float(row["reference"])
    method = next(m for m in doc["methods"] if m["name"] == engine)
    return worst, values, exact, doc["samples"], float(method["settings"]["dt"])


def zero_speed(w1, n1, w2, n2):
    b = (n1 - n2) / (w2 * w2 - w1 * w1)
    return math.sqrt((n1 + b * w1 * w1) / b)


w = math.pi / 30  # rad/s per rpm
print("| engine | definition | setting | dt [s] | s | s̈ | contact force | deepest penetration [m] | "
      "jump speed [rpm] (exact) |")
print("|---|---|---|---|---|---|---|---|---|")
with tempfile.TemporaryDirectory() as folder:
    folder = Path(folder)
    for engine, name, speed, (slow, fast), jump_at, depth, settings_list in CASES:
        for settings in settings_list:
            worst, values, exact, samples, dt = run(engine, name, speed, speed, settings, folder)
            deepest = max(depth(values, i) for i in range(samples) if ("s.follower", i) in values)
            runs = [run(engine, name, speed, rpm, settings, folder) for rpm in (slow, fast)]
            key = ("f.contact", jump_at)
            exact_jump = zero_speed(slow * w, runs[0][2][key], fast * w, runs[1][2][key]) / w
            # A force that oscillates (chatter, ringing) gives no speed: no number for it.
            steady = all(r[0]["f.contact"] < 1.0 for r in runs)
            jump = (f"{zero_speed(slow * w, runs[0][1][key], fast * w, runs[1][1][key]) / w:.3f}"
                    if steady else "none: the force oscillates")
            label = ", ".join(f"`{s}`" for s in settings) or "defaults"
            cells = [f"{worst[c]:.2g} %" for c in ("s.follower", "sddot.follower", "f.contact")]
            print(f"| {engine} | `{name}` at {speed} rpm | {label} | {dt:.3g} | " + " | ".join(cells) +
                  f" | {deepest:.2g} | {jump} ({exact_jump:.3f}) |")
