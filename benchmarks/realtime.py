"""Solver speed: real-time factor through a pitch doublet, and the static trail solve.

    python3 benchmarks/realtime.py [--elements 40] [--duration 20] [--json] [--effects]

The case is the KDC-10 pod's 75 ft hose and drogue (data-sheet dimensions and
masses, hose full of fuel) at 15 000 ft and 254 KCAS, with a 2 m/s side wind so
the motion is three-dimensional, and a 0.3 m, 2 s sine pitch doublet at the tow
point. The structural constants are nominal (EI 50 N m^2, EA 2 MN). Each figure
is the best of five runs on one core, after a warm-up run that loads the
compiled kernel.

--effects turns on every effect of `solver.effects` that acts on this model at
its defaults (the KDC-10 data sheet and engagement 7's 410 000 lb for the
tanker wake; the receiver closing from 40 m at 2 m/s for the bow wave; light
turbulence; a 3 m/s gust); reel_lag needs the drum reel and costs a few flops a
step, sensor_lag is not physics.
"""
from __future__ import annotations

import argparse
import json
import platform
import time

import numpy as np

from solver.atmosphere import isa, kcas_to_tas
from solver.drogue import DrogueProperties
from solver.hose import HoseProperties
from solver.integrate import simulate
from solver.model import Model, Trajectory
from solver.statics import solve_static
from solver.units import FT, LB
from solver.wind import uniform


def doublet_model(n_elements: int, duration: float) -> Model:
    st = isa(15000 * FT)
    u = kcas_to_tas(254.0, 15000.0)
    hose = HoseProperties(length=75 * FT, outer_diameter=0.0635, inner_diameter=0.0445,
                          dry_mass_per_length=2.2, EI=50.0, EA=2.0e6, bending_damping=2.0,
                          axial_damping=300.0)
    drogue = DrogueProperties(mass=27.0, diameter=0.68, cd=0.82, cl=0.18, cp_aft_of_hinge=0.40)
    t = np.linspace(0.0, duration, int(duration * 100) + 1)
    z = np.where((t > 1.0) & (t < 3.0), 0.3 * np.sin(np.pi * (t - 1.0)), 0.0)
    tow = Trajectory(t, np.column_stack([np.zeros_like(t), np.zeros_like(t), z]))
    return Model(hose, n_elements, st.density, st.kinematic_viscosity, wind=uniform([u, 2.0, 0.0]),
                 drogue=drogue, tow=tow)


def with_all_effects(m: Model, duration: float) -> Model:
    from solver.effects import EffectContext, TankerGeometry, apply_effects
    ctx = EffectContext(true_airspeed=m.wind.mean_speed, air_density=m.air_density, altitude_m=15000 * FT,
                        duration_s=duration, tanker=TankerGeometry(50.41, 4.0, 1.3, 16.5),
                        gross_weight_kg=410000 * LB)
    effects = {"tanker_wake": {}, "turbulence": {}, "bow_wave": {"start_gap_m": 40.0}, "steady_wind":
               {"vertical_mps": 1.0}, "gust": {}, "drogue_lift": {"scale": 0.5}, "drogue_drag": {},
               "hose_drag": {}, "hose_stiffness": {}}
    return apply_effects(m, effects, ctx)


def best_of(fn, repeat=5):
    best = np.inf
    out = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--elements", type=int, default=40)
    ap.add_argument("--duration", type=float, default=20.0)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--effects", action="store_true", help="every effect that acts on this model on")
    a = ap.parse_args()
    m = doublet_model(a.elements, a.duration)
    if a.effects:
        m = with_all_effects(m, a.duration)
    s0 = solve_static(m)
    simulate(m, 0.5, s0)   # warm-up: loads the cached kernel
    static_s, _ = best_of(lambda: solve_static(m))
    sim_s, res = best_of(lambda: simulate(m, a.duration, s0), repeat=3)
    out = {
        "machine": f"{platform.machine()} {platform.processor() or ''}".strip(),
        "elements": a.elements,
        "effects": bool(a.effects),
        "dt_s": res.dt,
        "simulated_s": a.duration,
        "wall_s": sim_s,
        "realtime_factor": a.duration / sim_s,
        "static_solve_ms": static_s * 1e3,
        "drogue_static_xyz_m": [float(v) for v in s0.pos[-1]],
        "drogue_lateral_peak_m": float(np.max(np.abs(res.drogue_xyz[:, 1]))),
    }
    if a.json:
        print(json.dumps(out))
        return
    print(f"{a.elements}-element 3D hose + drogue, pitch doublet, {a.duration:g} s simulated")
    print(f"  step {res.dt * 1e3:.3f} ms, wall {sim_s:.3f} s, real-time factor {out['realtime_factor']:.0f}x")
    print(f"  static trail solve {out['static_solve_ms']:.1f} ms; drogue at "
          f"x={s0.pos[-1, 0]:.2f} y={s0.pos[-1, 1]:.2f} z={s0.pos[-1, 2]:.2f} m")


if __name__ == "__main__":
    main()
