#!/usr/bin/env python3
"""The engines' joint friction against the exact reference (docs/engines.md, "Joint friction"):
the worst % of peak of the friction channels, of the driver effort (kinematic) or the angle or
slide (dynamics), of the energy balance, the creep and the steps, per engine and setting.
Usage: measure_friction.py CROSSLINK"""
import json, re, subprocess, sys
cl = sys.argv[1]
runs = [("ode", n, s) for n, s in [
  ("fourbar_friction_circles", []), ("fourbar_friction_circles", ["max_step_angle=0.005"]),
  ("fourbar_friction_circles", ["friction_load=last", "cfm=1e-9"]),
  ("fourbar_friction_circles", ["friction_load=last", "cfm=1e-9", "max_step_angle=0.005"]),
  ("fourbar_friction_circles", ["friction_load=last"]),
  ("slider_crank_friction", []), ("slider_crank_friction", ["max_step_angle=0.005"]),
  ("slider_crank_friction", ["friction_load=last"]),
  ("slider_crank_friction", ["friction_load=last", "max_step_angle=0.005"]),
  ("bevan_eccentric_friction", []), ("bevan_eccentric_friction", ["friction_load=last"]),
  ("block_sliding_to_rest", []), ("block_sliding_to_rest", ["friction_cfm=1e-6"]),
  ("block_sliding_to_rest", ["friction_cfm=1e-10"]),
  ("pendulum_pin_friction", []), ("pendulum_pin_friction", ["max_step_angle=0.00125"]),
  ("pendulum_pin_friction", ["max_step_angle=0.000625"]),
  ("pendulum_pin_friction", ["friction_cfm=1e-6"]),
  ("gear_pair_bearing_friction", []), ("gear_pair_bearing_friction", ["friction_load=last"]),
]] + [("bullet", n, s) for n, s in [
  ("fourbar_friction_circles", []), ("fourbar_friction_circles", ["max_step_angle=0.005"]),
  ("fourbar_friction_circles", ["friction_load=last"]),
  ("fourbar_friction_circles", ["friction_cfm=1e-14"]),
  ("fourbar_friction_circles", ["friction_cfm=1e-16"]),
  ("slider_crank_friction", []), ("slider_crank_friction", ["max_step_angle=0.005"]),
  ("slider_crank_friction", ["friction_load=last"]),
  ("slider_crank_friction", ["friction_load=last", "max_step_angle=0.005"]),
  ("slider_crank_friction", ["friction_cfm=1e-6"]),
  ("bevan_eccentric_friction", []), ("bevan_eccentric_friction", ["friction_load=last"]),
  ("bevan_eccentric_friction", ["friction_cfm=1e-8"]),
  ("block_sliding_to_rest", []), ("block_sliding_to_rest", ["friction_cfm=1e-6"]),
  ("pendulum_pin_friction", []), ("pendulum_pin_friction", ["max_step_angle=0.00125"]),
  ("pendulum_pin_friction", ["max_step_angle=0.000625"]),
  ("gear_pair_bearing_friction", []), ("gear_pair_bearing_friction", ["friction_load=last"]),
]] + [("simbody", n, s) for n, s in [
  ("fourbar_friction_circles", []), ("fourbar_friction_circles", ["friction_load=last"]),
  ("slider_crank_friction", []), ("slider_crank_friction", ["friction_load=last"]),
  ("slider_crank_friction", ["friction_load=last", "max_step_angle=0.00125"]),
  ("bevan_eccentric_friction", []),
  ("block_sliding_to_rest", []), ("block_sliding_to_rest", ["friction_speed=1e-3"]),
  ("block_sliding_to_rest", ["friction_speed=1e-5"]),
  ("pendulum_pin_friction", []), ("pendulum_pin_friction", ["friction_speed=1e-3"]),
  ("pendulum_pin_friction", ["friction_speed=1e-5"]),
  ("pendulum_pin_friction", ["friction_speed=1e-6"]),
  ("gear_pair_bearing_friction", []), ("gear_pair_bearing_friction", ["friction_load=last"]),
]] + [("mujoco", n, s) for n, s in [
  ("block_sliding_to_rest", []), ("block_sliding_to_rest", ["friction_load=last"]),
  ("pendulum_pin_friction", []), ("pendulum_pin_friction", ["friction_solref=0.005 1"]),
  ("pendulum_pin_friction", ["friction_solref=0.02 1"]),
  ("pendulum_pin_friction", ["max_step_angle=0.000625"]),
  ("fourbar_friction_circles", []), ("fourbar_friction_circles", ["friction_load=last"]),
  ("gear_pair_bearing_friction", []), ("gear_pair_bearing_friction", ["friction_load=last"]),
]]
print("| engine | definition | settings (besides the defaults) | friction | effort or coordinate | energy balance | creep | steps |")
print("|---|---|---|---|---|---|---|---|")
for engine, name, sets in runs:
    cmd = [cl, "compare", f"mechanisms/friction/{name}.toml", "--engines", "analytic," + engine, "--json", "-"]
    for s in sets: cmd += ["--set", f"{engine}:" + s]
    d = json.loads(subprocess.run(cmd, capture_output=True, text=True).stdout)
    ode = [m for m in d["methods"] if m["name"] == engine][0]
    setting = ", ".join(f"`{s}`" for s in sets) or "defaults"
    if not ode["ok"]:
        msg = ode["message"].split(";")[0][:90]
        print(f"| {engine} | {name} | {setting} | fails: {msg} | | | | |"); continue
    ch = {c["channel"]: c for c in d["channels"] if c["method"] == engine}
    fr = max(c["max_pct_of_peak"] for k, c in ch.items() if k.startswith("friction_"))
    if "torque.driver" in ch and not d.get("dynamics"):
        eff = f"torque {ch['torque.driver']['max_pct_of_peak']:.3g} %"
    else:
        k = "angle.arm" if "angle.arm" in ch else "s.slide"
        eff = f"{k} {ch[k]['max_pct_of_peak']:.3g} %"
    en = f"{ch['energy.error']['max_pct_of_peak']:.2g} %" if "energy.error" in ch else "-"
    m = re.search(r"creep: (\S+ \S+)", ode["message"])
    creep = m.group(1) if m else "-"
    steps = ode["cost"].get("steps", "")
    if m := re.search(r"took (\d+) internal steps", ode["message"]): steps = f"{m.group(1)} internal"  # Simbody's own
    print(f"| {engine} | {name} | {setting} | {fr:.3g} % | {eff} | {en} | {creep} | {steps} |")
