"""The hose chain's bookkeeping that `solver.integrate.simulate` and
`solver.stepper.Stepper` share around the compiled kernel: the kernel's tables,
the array capacity the reel needs, the reel's state and set point, the remesh at
the reel exit, and the errors the kernel's failure codes stand for.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import PchipInterpolator

from solver import kernel as K
from solver.model import Model
from solver.state import State


class DivergenceError(RuntimeError):
    """The simulation produced non-finite or impossible values."""


def tables(model: Model, t_end: float):
    """The kernel's prescribed-motion tables up to t_end: tow point, end constraint
    and prescribed reel payout, each as (t0, dt, rows)."""
    tow_t0, tow_dt, tow_tab = model.tow.table(t_end)
    if model.end is not None:
        end_t0, end_dt, end_tab = model.end.path.table(t_end)
    else:
        end_t0, end_dt, end_tab = 0.0, 1.0, np.zeros((2, 6))
    if model.reel.mode == "prescribed":
        r = model.reel
        t = np.arange(r.payout_t[0], max(r.payout_t[-1], t_end) + 2 * 0.002, 0.002)
        f = PchipInterpolator(r.payout_t, r.payout_length, extrapolate=False)
        tc = np.clip(t, r.payout_t[0], r.payout_t[-1])
        L = f(tc)
        Ld = f.derivative()(tc)
        Ld[(t < r.payout_t[0]) | (t > r.payout_t[-1])] = 0.0
        reel_t0, reel_dt, reel_tab = float(t[0]), 0.002, np.ascontiguousarray(np.column_stack([L, Ld]))
    else:
        reel_t0, reel_dt, reel_tab = 0.0, 1.0, np.zeros((2, 2))
    return (tow_t0, tow_dt, tow_tab, end_t0, end_dt, end_tab, reel_t0, reel_dt, reel_tab)


def node_capacity(model: Model, n_hose: int) -> int:
    """Nodes the kernel's arrays need: room for all the hose the reel can pay out
    (the payout table's longest, the whole stowed hose on a drum, the hose as it
    is on a locked reel) at the nominal element length, the tow point and the
    drogue."""
    r = model.reel
    if r.mode == "prescribed":
        L_max = float(np.max(r.payout_length))
    elif r.mode == "drum":
        L_max = model.hose.stowed_length
    else:
        L_max = model.hose.length
    nh_max = max(n_hose, int(math.ceil(L_max / model.element_length)) + 3)
    return nh_max + 1 + (1 if model.has_drogue else 0)


def _describe_node(model: Model, n: int, i: int) -> str:
    if model.has_drogue and i == n - 1:
        return "the drogue (node %d)" % i
    if i == 0:
        return "the tow point"
    return f"node {i} (end of hose element {i - 1}, {i} from the tow point)"


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


def reel_set_point(model: Model, state0: State, rest: np.ndarray) -> float:
    """Tension the constant-tension reel holds: given, or the initial exit tension."""
    r = model.reel
    if r.mode != "drum" or r.torque_law != "constant_tension":
        return 0.0
    if r.tension is not None:
        return float(r.tension)
    d = state0.pos[1] - state0.pos[0]
    l = float(np.linalg.norm(d))
    ka = model.hose.constants(rest[0])[0]
    return ka * (l - rest[0])


def remesh(code, model, nh, pos, vel_half, acc, rest, mass, L_out):
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
