"""Static equilibrium (steady trail) by Newton's method.

The unknowns are the free nodes' positions; the residual is the net force on
each with every velocity zero (aerodynamics on the steady wind). The first guess
comes from marching the string equations (no bending) up from the free end,
which is exact for a string, so Newton mostly has to add bending and the hinge. The Jacobian is built by finite differences in
groups of nodes five apart (a node's force depends on its neighbours up to two
away), 15 force evaluations per Jacobian.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.linalg import solve_banded

from solver import kernel as K
from solver.model import Model
from solver.state import State


class StaticSolveError(RuntimeError):
    pass


# A node's force depends on nodes up to two away, three coordinates each: the
# Jacobian's half-bandwidth is 3*2 + 2 = 8 (banded solve, O(n) instead of O(n^3)).
BAND = 8


def _to_banded(A: np.ndarray, band: int) -> np.ndarray:
    """LAPACK band storage of A with `band` sub- and super-diagonals."""
    n = A.shape[0]
    ab = np.zeros((2 * band + 1, n))
    for k in range(-band, band + 1):
        d = np.diagonal(A, k)
        if k >= 0:
            ab[band - k, k:] = d
        else:
            ab[band - k, :n + k] = d
    return ab


def _forces(model, P, t, arrays, pos, work):
    n, mass, rest, ka, ca, kb, cb = arrays
    vel = np.zeros_like(pos)
    F = np.zeros((n, 3))
    tension = np.zeros(n)
    K.compute_forces(t, P, n, model.n_elements, pos, vel, mass, rest, ka, ca, kb, cb,
                     model.wind.params, F, tension, work)
    return F, tension


def _aero_element(model, P, w, tvec, l0):
    """Steady aerodynamic force on a hose element of direction tvec at rest in wind w."""
    u = w @ tvec
    vn_vec = w - u * tvec
    vn = float(np.linalg.norm(vn_vec))
    D = model.hose.outer_diameter
    cdn = K._cdn(P, vn * D / model.kinematic_viscosity)
    s = model.hose_drag_scale
    fn = 0.5 * model.air_density * cdn * D * l0 * vn * vn_vec * s
    fa = 0.5 * model.air_density * model.hose.ca0 * math.pi * D * l0 * abs(u) * u * tvec * s
    return fn + fa


def _drogue_aero(model, t, point):
    d = model.drogue
    w = model.wind.velocity(t, point[None, :])[0]
    V = float(np.linalg.norm(w))
    f = 0.5 * model.air_density * V * d.drag_area * w
    if V > 1e-9 and d.lift_area != 0:
        u = w / V
        lift_dir = np.array([0.0, 0.0, 1.0]) - u[2] * u
        nrm = np.linalg.norm(lift_dir)
        if nrm > 1e-9:
            f = f + 0.5 * model.air_density * V * V * d.lift_area * lift_dir / nrm
    return f


def string_guess(model: Model, t: float, rest: np.ndarray, P: np.ndarray, fallback_dir) -> np.ndarray:
    """Node positions of the string solution (no bending), marched from the free end.

    With S_e the force vector of element e (tension times its unit vector, tow
    point to free end), node k's balance is S_{k-1} = S_k + F_ext(k); element
    k-1's own drag depends on its direction, found by a few fixed-point passes.
    The whole march runs twice so that position-dependent wind is seen where
    the hose actually lies."""
    g = np.asarray(model.gravity, dtype=float)
    mu = model.hose.mass_per_length
    nh = len(rest)
    tow = model.tow.at(t)
    fallback = np.asarray(fallback_dir, dtype=float)
    fallback = fallback / np.linalg.norm(fallback)
    end = tow + fallback * float(np.sum(rest))
    for _ in range(2):
        S = model.tip_mass * g
        link = None
        if model.has_drogue:
            d = model.drogue
            s = d.cp_aft_of_hinge / d.link_length
            fa = _drogue_aero(model, t, end)
            Fd = s * fa + d.mass * g
            link_dir = Fd / np.linalg.norm(Fd) if np.linalg.norm(Fd) > 1e-9 else fallback
            link = link_dir * d.link_length
            S = S + Fd + (1 - s) * fa
        x = end.copy()
        pts = [x.copy()]
        half_aero_below = np.zeros(3)
        tvec = fallback.copy()
        for k in range(nh, 0, -1):
            l0 = rest[k - 1]
            l_below = rest[k] if k < nh else 0.0
            base = S + 0.5 * mu * (l0 + l_below) * g + half_aero_below
            Se = base
            # the wind at the element's lower end: the first guess needs no finer sampling
            w = model.wind.velocity(t, x[None, :])[0]
            for _ in range(5):
                fa = _aero_element(model, P, w, tvec, l0)
                Se = base + 0.5 * fa
                nS = np.linalg.norm(Se)
                if nS < 1e-12:
                    break
                tvec = Se / nS
            T = float(np.linalg.norm(Se))
            ka = model.hose.constants(l0)[0]
            x = x - l0 * (1.0 + T / (ka * l0)) * tvec
            pts.append(x.copy())
            S = Se
            half_aero_below = 0.5 * fa
        hose = np.array(pts[::-1])
        shift = tow - hose[0]
        hose = hose + shift
        end = end + shift
    if link is not None:
        hose = np.vstack([hose, hose[-1] + link])
    return hose


def solve_static(model: Model, t: float = 0.0, tol: float = 1e-7, max_iter: int = 200,
                 guess: np.ndarray | None = None) -> State:
    """Steady equilibrium at time t with the reel locked at the hose length.

    Newton's method globalised by pseudo-transient continuation (Kelley & Keyes
    1998): each step solves (M/dtau - J) dx = F, an implicit step of the
    overdamped motion M x' = F, with dtau grown by switched evolution
    relaxation (dtau *= |F_old|/|F_new|) so the iteration becomes plain Newton
    near the answer. From the string guess the drogue-less hose's free end (zero
    tension, bending on) is outside Newton's basin; this brings it in.
    Converged when the largest nodal force residual is below `tol` times the
    largest load on the hose (tension at the tow point, or its weight)."""
    nh = model.n_elements
    l = model.element_length
    rest = np.full(nh, l)
    arrays = model.build_arrays(nh, rest)
    n, mass = arrays[0], arrays[1]
    P = model.params(nh, rest)
    work = np.zeros((6, n, 3))
    fallback = model.clamp.direction if model.clamp is not None else (1.0, 0.0, 0.0)
    pos = string_guess(model, t, rest, P, fallback) if guess is None else np.array(guess, dtype=float)
    if pos.shape != (n, 3):
        raise StaticSolveError(f"initial guess has shape {pos.shape}, expected {(n, 3)}")
    F, tension = _forces(model, P, t, arrays, pos, work)
    weight = model.hose.mass_per_length * model.hose.length * np.linalg.norm(model.gravity)
    if model.has_drogue:
        weight += model.drogue.mass * np.linalg.norm(model.gravity)
    f_ref = max(weight, float(np.max(np.abs(tension))), 1e-6)
    nfree = n - 1
    scale = l * 1e-6
    mdiag = np.repeat(mass[1:], 3)
    # start where the pseudo-time inertia matches the transverse (drag and bending)
    # stiffness, far below the axial one, so the first steps move the hose's shape
    k_soft = max(f_ref / l, 1e-6)
    dtau = 10.0 * float(np.max(mdiag)) / k_soft

    def resid(p):
        Fp, _ = _forces(model, P, t, arrays, p, work)
        return Fp[1:].ravel()

    r = F[1:].ravel()
    rnorm = float(np.linalg.norm(r))
    for it in range(max_iter):
        err = float(np.max(np.abs(r)))
        if err < tol * f_ref:
            return State(t, pos, np.zeros_like(pos), rest, model.hose.length, 0.0)
        J = np.zeros((3 * nfree, 3 * nfree))
        for color in range(5):
            nodes = np.arange(1 + color, n, 5)
            for c in range(3):
                pp = pos.copy()
                pp[nodes, c] += scale
                dr = (resid(pp) - r) / scale
                for i in nodes:
                    col = 3 * (i - 1) + c
                    lo = max(1, i - 2)
                    hi = min(n - 1, i + 2)
                    J[3 * (lo - 1):3 * hi, col] = dr[3 * (lo - 1):3 * hi]
        for _ in range(30):
            A = np.diag(mdiag / dtau) - J
            try:
                dx = solve_banded((BAND, BAND), _to_banded(A, BAND), r)
            except (np.linalg.LinAlgError, ValueError):
                dtau *= 0.25
                continue
            trial = pos.copy()
            trial[1:] += dx.reshape(-1, 3)
            rt = resid(trial)
            rt_norm = float(np.linalg.norm(rt)) if np.all(np.isfinite(rt)) else np.inf
            if rt_norm < 10.0 * rnorm:
                break
            dtau *= 0.25
        else:
            raise StaticSolveError(f"static solve stalled at iteration {it}: residual "
                                   f"{err:.3g} N (tolerance {tol * f_ref:.3g} N)")
        dtau *= min(10.0, max(0.1, rnorm / max(rt_norm, 1e-300)))
        pos, r, rnorm = trial, rt, rt_norm
    raise StaticSolveError(
        f"static solve did not converge in {max_iter} iterations: largest residual "
        f"{float(np.max(np.abs(r))):.3g} N (tolerance {tol * f_ref:.3g} N)")
