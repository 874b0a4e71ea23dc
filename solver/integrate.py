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
from solver.model import Model
from solver.result import SimulationResult
from solver.state import State
from solver.statics import solve_static


class DivergenceError(RuntimeError):
    """The simulation produced non-finite or impossible values."""


def _tables(model: Model, t_end: float):
    tow_t0, tow_dt, tow_tab = model.tow.table(t_end)
    if model.end is not None:
        end_t0, end_dt, end_tab = model.end.path.table(t_end)
    else:
        end_t0, end_dt, end_tab = 0.0, 1.0, np.zeros((2, 6))
    if model.reel.mode == "prescribed":
        r = model.reel
        t = np.arange(r.payout_t[0], max(r.payout_t[-1], t_end) + 2 * 0.002, 0.002)
        from scipy.interpolate import PchipInterpolator
        f = PchipInterpolator(r.payout_t, r.payout_length, extrapolate=False)
        tc = np.clip(t, r.payout_t[0], r.payout_t[-1])
        L = f(tc)
        Ld = f.derivative()(tc)
        Ld[(t < r.payout_t[0]) | (t > r.payout_t[-1])] = 0.0
        reel_t0, reel_dt, reel_tab = float(t[0]), 0.002, np.ascontiguousarray(np.column_stack([L, Ld]))
    else:
        reel_t0, reel_dt, reel_tab = 0.0, 1.0, np.zeros((2, 2))
    return (tow_t0, tow_dt, tow_tab, end_t0, end_dt, end_tab, reel_t0, reel_dt, reel_tab)


def _describe_node(model: Model, n: int, i: int) -> str:
    if model.has_drogue and i == n - 1:
        return "the drogue (node %d)" % i
    if i == 0:
        return "the tow point"
    return f"node {i} (end of hose element {i - 1}, {i} from the tow point)"


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

    tabs = _tables(model, t_end)
    l_nom = model.element_length
    # room for the hose the reel can pay out
    if model.reel.mode == "prescribed":
        L_max = float(np.max(model.reel.payout_length))
    elif model.reel.mode == "drum":
        L_max = model.hose.stowed_length
    else:
        L_max = model.hose.length
    nh = state0.n_hose
    nh_max = max(nh, int(math.ceil(L_max / l_nom)) + 3)
    n_extra = 1 if model.has_drogue else 0
    n_max = nh_max + 1 + n_extra

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
    reel_tension = _reel_set_point(model, state0, rest)
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
        pos, vel_half, acc, rest, dflux = _remesh(code, model, nh, pos, vel_half, acc, rest, mass,
                                                  reel[0])
        reel[4:7] += dflux
        nh = len(rest)
        n, mass, rest_all, ka, ca, kb, cb = model.build_arrays(nh, rest)
        P = model.params(nh, rest, reel_tension)
    return SimulationResult.from_arrays(
        model=model, t=out_t[:rec], pos=out_pos[:rec], vel=out_vel[:rec], tension=out_tension[:rec],
        reel=out_reel[:rec], end_force=out_end[:rec], energy=out_energy[:rec], n_nodes=out_n[:rec],
        balance=out_mom[:rec], dt=dt, reel_tension_set=reel_tension)


def reel_state(model: Model, state0: State, dt: float) -> np.ndarray:
    """The kernel's `reel` array at the start: length and speed, the bookkeeping
    sums at zero, and the drive hold-back's lag and ring of past speeds (one per
    step of dead time) at the initial speed."""
    r = model.reel
    ring = max(1, int(round(r.drive_dead_time / dt))) if r.drive_hold > 0 else 0
    reel = np.zeros(K.REEL_RING + ring)
    reel[0] = state0.reel_length
    reel[1] = state0.reel_speed
    reel[K.REEL_FILT] = state0.reel_speed
    reel[K.REEL_RING:] = state0.reel_speed
    return reel


def check_failure(code: int, t_bad: float, model: Model, n: int, bad: int, P: np.ndarray, what_ran: str) -> None:
    """Raise the DivergenceError a kernel failure code stands for (naming the time
    and the node where it began); return for the codes that only ask for a remesh."""
    if code in (K.NONFINITE, K.OVERSPEED):
        what = "non-finite position or velocity" if code == K.NONFINITE else \
            f"speed above {P[K.P_VMAX]:.0f} m/s (energy blow-up)"
        raise DivergenceError(
            f"{what_ran} diverged at t={t_bad:.4f} s: {what} first at {_describe_node(model, n, bad)}")
    if code == K.REEL_LIMIT:
        raise DivergenceError(f"at t={t_bad:.4f} s the reel has taken in all the hose but "
                              f"{int(P[K.P_NE_MIN])} elements, the fewest the model keeps")


def _reel_set_point(model: Model, state0: State, rest: np.ndarray) -> float:
    """Tension the constant-tension reel holds: given, or the initial exit tension."""
    r = model.reel
    if r.mode != "drum" or r.torque_law != "constant_tension":
        return 0.0
    if r.tension is not None:
        return float(r.tension)
    if model.reel_tension is not None:
        return float(model.reel_tension)
    d = state0.pos[1] - state0.pos[0]
    l = float(np.linalg.norm(d))
    ka = model.hose.constants(rest[0])[0]
    return ka * (l - rest[0])


def _remesh(code, model, nh, pos, vel_half, acc, rest, mass, L_out):
    """Insert (reel paying out) or remove (taking in) the node next to the reel exit.

    Inserting splits the exit element one nominal length from node 1; linear
    interpolation of the velocity there conserves momentum (the new node's mass
    comes from nodes 0 and 1 in the interpolation's proportions). Removing node 1
    hands the share of its mass that stays outside to node 2 with its momentum;
    the share that goes into the pod leaves with its own. Returns the change of
    the free nodes' momentum, which is what crossed the reel exit (the masses
    before are those of the last step, so the exit element's latest growth is
    booked here too)."""
    l_nom = model.element_length
    r0 = L_out - float(np.sum(rest[1:]))
    p_before = mass[1:] @ vel_half[1:]
    if code == K.REMESH_GROW:
        f = l_nom / r0
        x_new = pos[1] + f * (pos[0] - pos[1])
        v_new = vel_half[1] + f * (vel_half[0] - vel_half[1])
        a_new = acc[1] + f * (acc[0] - acc[1])
        pos = np.insert(pos, 1, x_new, axis=0)
        vel_half = np.insert(vel_half, 1, v_new, axis=0)
        acc = np.insert(acc, 1, a_new, axis=0)
        rest = np.concatenate([[r0 - l_nom, l_nom], rest[1:]])
        mass_new = model.build_arrays(nh + 1, rest)[1]
    else:
        rest = np.concatenate([[r0 + rest[1]], rest[2:]])
        mass_new = model.build_arrays(nh - 1, rest)[1]
        m2_old = mass[2]
        vel_half[2] = (m2_old * vel_half[2] + (mass_new[1] - m2_old) * vel_half[1]) / mass_new[1]
        pos = np.delete(pos, 1, axis=0)
        vel_half = np.delete(vel_half, 1, axis=0)
        acc = np.delete(acc, 1, axis=0)
    dflux = mass_new[1:] @ vel_half[1:] - p_before
    return (np.ascontiguousarray(pos), np.ascontiguousarray(vel_half), np.ascontiguousarray(acc),
            rest, dflux)
