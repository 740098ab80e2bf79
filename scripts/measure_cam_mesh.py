#!/usr/bin/env python3
"""MuJoCo's mesh of a cam profile that is not a disc against the exact reference (docs/engines.md,
"Cams"): per definition, facets a turn (cam_facets) and setting, the worst % of peak of the
follower's travel, velocity, acceleration and the contact force, and the run's wall time. The
definitions: translating_roller_345.toml without its groove, held on by a spring (the variant of
EngineCams.MuJoCoHoldsAFollowerOnAMeshOfAProfileThatIsNotADisc), and spring_cam_jump.toml (a
flat face), each at 300 rpm, below its jump speed.
Usage: measure_cam_mesh.py CROSSLINK   (prints a Markdown table)"""
import json, math, subprocess, sys, tempfile, time
from pathlib import Path

cl = sys.argv[1]


def roller_345_spring():
    text = Path("mechanisms/cams/translating_roller_345.toml").read_text()
    for old, new in [
        ('closure = "form"          # a groove holds the follower both ways: no spring keeps it '
         'on\n', ""),
        ("D = [0.01, 0] }", "D = [0.01, 0], S = [0.01, -0.1] }"),
        ("[driver]", '[[spring]]\nname = "return_spring"\nlinks = ["ground", "follower"]\n'
         'points = ["S", "C"]\nstiffness = 200\nfree_length = 0.1\n\n[driver]')]:
        assert old in text, old
        text = text.replace(old, new)
    return text


def spring_cam_jump_300():
    text = Path("mechanisms/cams/spring_cam_jump.toml").read_text()
    old = "\nspeed = 400 "
    assert old in text
    return text.replace(old, "\nspeed = 300 ")


def disc_through_points():
    """eccentric_roller_spring's disc (R = 0.09, e = 0.04) as a profile through 360 of its points,
    r = e cos phi + sqrt(R^2 - e^2 sin^2 phi): the spline gives the disc back to about 1e-10 m
    (fourth order; CamJoints.PointsProfileConvergesToTheDiscItSamples), and MuJoCo meshes it
    where it holds the disc itself as a sphere (docs/engines.md, "Cams": 5e-4 % of peak)."""
    text = Path("mechanisms/cams/eccentric_roller_spring.toml").read_text()
    old = 'shape = "eccentric"\nradius = 0.09\neccentricity = 0.04\nlobe_angle = 0\n'
    assert old in text
    r = [0.04 * math.cos(math.radians(a)) +
         math.sqrt(0.09 ** 2 - (0.04 * math.sin(math.radians(a))) ** 2) for a in range(360)]
    points = ", ".join(f"[{a}, {r[a]!r}]" for a in range(360))
    return text.replace(old, f'shape = "points"\npoints = [{points}]\n')


CASES = [("`translating_roller_345` held by a spring", roller_345_spring),
         ("`spring_cam_jump` at 300 rpm", spring_cam_jump_300),
         ("`eccentric_roller_spring`'s disc through 360 points", disc_through_points)]
SETTINGS = [["cam_facets=360"], [], ["cam_facets=5760"], ["dt=4e-5"],
            ["contact_solref=0.0004 1"], ["cam_facets=5760", "contact_solref=0.0004 1"]]
CHANNELS = ("s.follower", "sdot.follower", "sddot.follower", "f.contact")

print("| definition | setting | s | ṡ | s̈ | contact force | run [s] |")
print("|---|---|---|---|---|---|---|")
with tempfile.TemporaryDirectory() as folder:
    toml, out = Path(folder) / "cam.toml", Path(folder) / "run.json"
    for label, text in CASES:
        toml.write_text(text())
        for settings in SETTINGS:
            args = [cl, "compare", str(toml), "--engines", "mujoco", "--json", str(out)]
            for s in settings:
                args += ["--set", f"mujoco:{s}"]
            start = time.perf_counter()
            subprocess.run(args, capture_output=True, check=False)
            wall = time.perf_counter() - start
            doc = json.loads(out.read_text())
            worst = {c["channel"]: c["max_pct_of_peak"] for c in doc["channels"]
                     if c["method"] == "mujoco"}
            name = ", ".join(f"`{s}`" for s in settings) or "defaults (1440 facets)"
            print(f"| {label} | {name} | " + " | ".join(f"{worst[c]:.2g} %" for c in CHANNELS) +
                  f" | {wall:.1f} |")
