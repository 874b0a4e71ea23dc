"""Time integration: the one entry point that runs a model through time.

The compiled leapfrog (`solver.kernel.run_steps`) advances the state; this
module prepares its arrays, restarts it after every reel remesh (a node added
or removed at the reel exit), and turns its failure codes into errors that name
the time and the element where the trouble began.
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

from solver import kernel as K
from solver.chain import check_failure, node_capacity, reel_set_point, reel_state, remesh, tables
from solver.model import Model
from solver.result import SimulationResult
from solver.state import State
from solver.statics import solve_static


def simulate(model: Model, t_end: float, state0: Optional[State] = None, dt: Optional[float] = None,
             record_dt: float = 0.01, t_start: Optional[float] = None) -> SimulationResult:
    """Run `model` from `state0` (default: static equilibrium at t_start) to `t_end` (s).

    Outputs are recorded every `record_dt` seconds; the integration step `dt`
    defaults to the model's stable step, shortened to divide `record_dt`."""
    if t_start is None:
        t_start = state0.t if state0 is not None else float(model.tow.t[0])
    if state0 is None:
        state0 = solve_static(model, t_start)
    if not (t_end > t_start):
        raise ValueError(f"t_end {t_end!r} must be after the start time {t_start!r}")
    if abs(state0.reel_length - float(np.sum(state0.rest))) > 1e-9 * max(1.0, state0.reel_length):
        raise ValueError(f"initial state: reel_length {state0.reel_length:.6g} m differs from the sum "
                         f"of the element rest lengths {float(np.sum(state0.rest)):.6g} m")
    dt_stable = model.stable_step()
    dt = dt_stable if dt is None else float(dt)
    if not (0 < dt):
        raise ValueError("dt must be positive")
    rec_every = max(1, math.ceil(record_dt / dt - 1e-9))
    dt = record_dt / rec_every
    nsteps_total = int(round((t_end - t_start) / dt))
    nrec = nsteps_total // rec_every + 1

    tabs = tables(model, t_end)
    nh = state0.n_hose
    n_max = node_capacity(model, nh)

    out_t = np.full(nrec, np.nan)
    out_pos = np.full((nrec, n_max, 3), np.nan)
    out_vel = np.full((nrec, n_max, 3), np.nan)
    out_tension = np.full((nrec, n_max), np.nan)
    out_reel = np.full((nrec, 6), np.nan)
    out_end = np.zeros((nrec, 3))
    out_energy = np.full((nrec, 2), np.nan)
    out_mom = np.full((nrec, 11), np.nan)
    out_n = np.zeros(nrec, dtype=int)

    rest = state0.rest.copy()
    n, mass, rest_all, ka, ca, kb, cb = model.build_arrays(nh, rest)
    pos = state0.pos.copy()
    vel = state0.vel.copy()
    reel_tension = reel_set_point(model, state0, rest)
    P = model.params(nh, rest, reel_tension)
    work = np.zeros((6, n_max, 3))
    F = np.zeros((n, 3))
    ten = np.zeros(n)
    K.compute_forces(t_start, P, n, nh, pos, vel, mass, rest_all, ka, ca, kb, cb,
                     model.wind.params, F, ten, work)
    acc = F / mass[:, None]
    acc[0] = 0.0
    vel_half = vel - 0.5 * dt * acc
    reel = reel_state(model, state0, dt)
    end_reaction = np.zeros(3)

    wind_par = model.wind.params
    k_done = 0
    rec = 0
    while k_done < nsteps_total:
        t0 = t_start + k_done * dt
        code, steps, rec_new, bad = K.run_steps(
            t0, dt, nsteps_total - k_done, rec_every, k_done % rec_every, P, n, nh, pos, vel_half, acc, mass, rest_all,
            ka, ca, kb, cb, wind_par, *tabs, reel,
            out_t, out_pos, out_vel, out_tension, out_reel, out_end, out_energy, out_mom, rec, work,
            end_reaction)
        out_n[rec:rec_new] = n
        rec = rec_new
        k_done += steps
        if code == K.OK:
            break
        check_failure(code, t_start + k_done * dt, model, n, bad, P, "simulation")
        # remesh at the reel exit, then restart on the same record grid
        pos, vel_half, acc, rest, dflux = remesh(code, model, nh, pos, vel_half, acc, rest, mass, reel[0])
        reel[4:7] += dflux
        nh = len(rest)
        n, mass, rest_all, ka, ca, kb, cb = model.build_arrays(nh, rest)
        P = model.params(nh, rest, reel_tension)
    return SimulationResult.from_arrays(
        model=model, t=out_t[:rec], pos=out_pos[:rec], vel=out_vel[:rec], tension=out_tension[:rec],
        reel=out_reel[:rec], end_force=out_end[:rec], energy=out_energy[:rec], n_nodes=out_n[:rec],
        balance=out_mom[:rec], dt=dt, reel_tension_set=reel_tension)
