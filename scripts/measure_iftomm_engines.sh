#!/bin/sh
# The four engines on IFToMM A01, A02 and A03 (docs/engines-measured.md, "Four engines side by side"):
# one sweep per case for the time-stepping engines (MuJoCo, Bullet, ODE) over the grids of
# docs/dynamics.md, "IFToMM accuracy limits", and one for Simbody, whose error is set by its
# integrator's accuracy, not by the report spacing (dt: the case's sample interval). CSVs in
# docs/data/ (one run; the CPU times are the machine's at the time).
# Usage (from the source root): scripts/measure_iftomm_engines.sh [crosslink binary] [out dir]
set -e
X=${1:-build/app/crosslink}
OUT=${2:-docs/data}
run() { echo "== $*" >&2; /usr/bin/time -f "%e s wall, %U s user" nice "$X" sweep --quiet "$@"; }
run mechanisms/iftomm_a02_double_fourbar.toml --engines mujoco,bullet,ode --repeat 3 \
    --dt 2.5e-2,1e-2,5e-3,2e-3,1e-3,5e-4,2e-4,1e-4,5e-5 --csv "$OUT/iftomm_a02_engines.csv"
run mechanisms/iftomm_a02_double_fourbar.toml --engines simbody --repeat 1 --dt 2.5e-2 \
    --csv "$OUT/iftomm_a02_simbody.csv"
run mechanisms/andrews_squeezer.toml --engines mujoco,bullet,ode --repeat 3 \
    --dt 2e-5,1e-5,5e-6,2e-6,1e-6 --csv "$OUT/iftomm_a03_engines.csv"
run mechanisms/andrews_squeezer.toml --engines simbody --repeat 1 --dt 5e-4 \
    --csv "$OUT/iftomm_a03_simbody.csv"
run mechanisms/iftomm_a01_pendulum.toml --engines simbody --repeat 1 --dt 0.5 \
    --csv "$OUT/iftomm_a01_simbody.csv"
# A01's 2000 s: ODE only (MuJoCo's and Bullet's grid is docs/dynamics.md's, "IFToMM A01").
run mechanisms/iftomm_a01_pendulum.toml --engines ode --repeat 1 \
    --dt 1e-2,5e-3,2e-3,1e-3 --csv "$OUT/iftomm_a01_ode.csv"
run mechanisms/iftomm_a01_pendulum.toml --engines ode --repeat 1 --dt 3e-4 --max-steps 7000000 \
    --csv "$OUT/iftomm_a01_ode_fine.csv"
