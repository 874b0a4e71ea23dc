"""A `Model`: hose, drogue, reel, air and boundary conditions, ready to solve.

A model holds physics only; `workbench.cases` builds one from a case file.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np
from scipy.interpolate import PchipInterpolator
from scipy.linalg import eigvalsh_tridiagonal

from solver import kernel as K
from solver.drogue import DrogueProperties
from solver.hose import HoseProperties
from solver.reel import ReelProperties
from solver.units import G0
from solver.wind import WindField, uniform

TABLE_DT = 0.002   # s, sampling of prescribed-motion tables given to the kernel


@dataclass(frozen=True)
class Trajectory:
    """A prescribed point motion: positions (m, tow-point frame) at times (s).

    Interpolated by a shape-preserving cubic (PCHIP), whose derivative gives the
    velocity; held constant outside the table."""

    t: np.ndarray
    xyz: np.ndarray

    def __post_init__(self):
        t = np.asarray(self.t, dtype=float)
        xyz = np.asarray(self.xyz, dtype=float)
        if t.ndim != 1 or xyz.shape != (len(t), 3) or len(t) < 2:
            raise ValueError("trajectory needs times (n,) and positions (n, 3), n >= 2")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(xyz))):
            raise ValueError("trajectory holds non-finite values")
        if np.any(np.diff(t) <= 0):
            raise ValueError("trajectory times must increase")
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "xyz", xyz)

    @staticmethod
    def fixed(point=(0.0, 0.0, 0.0)) -> "Trajectory":
        p = np.asarray(point, dtype=float)
        return Trajectory(np.array([0.0, 1.0]), np.vstack([p, p]))

    def table(self, t_end: float) -> tuple[float, float, np.ndarray]:
        """Uniform table (t0, dt, rows of x y z vx vy vz) covering [t0, max(t_end, t[-1])]."""
        t0 = float(self.t[0])
        t1 = max(float(self.t[-1]), t_end) + 2 * TABLE_DT
        ts = np.arange(t0, t1 + TABLE_DT, TABLE_DT)
        tc = np.clip(ts, self.t[0], self.t[-1])
        f = PchipInterpolator(self.t, self.xyz, axis=0, extrapolate=False)
        pos = f(tc)
        vel = f.derivative()(tc)
        vel[(ts < self.t[0]) | (ts > self.t[-1])] = 0.0
        return t0, TABLE_DT, np.ascontiguousarray(np.hstack([pos, vel]))

    def at(self, t: float) -> np.ndarray:
        f = PchipInterpolator(self.t, self.xyz, axis=0, extrapolate=False)
        return f(np.clip(t, self.t[0], self.t[-1]))


@dataclass(frozen=True)
class EndConstraint:
    """The last node (drogue, or hose end) follows `path` from `t_on` to `t_off`
    (probe contact to disconnect); it is free outside that window.

    With `stiffness` 0 it follows the path exactly. Otherwise a spring-damper
    (N/m, N s/m) ties it to the path: the probe-drogue coupling's compliance,
    which spreads the impact of contact over the coupling's own time scale
    instead of one integration step, so the probe load is a physical number."""

    path: Trajectory
    t_on: float
    t_off: float = math.inf
    stiffness: float = 0.0
    damping: float = 0.0

    def __post_init__(self):
        if not (self.stiffness >= 0 and self.damping >= 0):
            raise ValueError("end constraint stiffness and damping must not be negative")


@dataclass(frozen=True)
class Clamp:
    """The first element held at the tow point in `direction` by a rotational
    spring of `stiffness_factor` x 2 EI / l (a clamped beam end stands for half an
    element of beam); damping likewise from the hose's bending damping."""

    direction: tuple = (1.0, 0.0, 0.0)
    stiffness_factor: float = 1.0


@dataclass
class Model:
    hose: HoseProperties
    n_elements: int
    air_density: float
    kinematic_viscosity: float
    wind: WindField = field(default_factory=lambda: uniform([0.0, 0.0, 0.0]))
    drogue: Optional[DrogueProperties] = None
    reel: ReelProperties = field(default_factory=ReelProperties)
    tow: Trajectory = field(default_factory=Trajectory.fixed)
    end: Optional[EndConstraint] = None
    clamp: Optional[Clamp] = None
    tip_mass: float = 0.0
    gravity: tuple = (0.0, 0.0, -G0)
    hose_drag_scale: float = 1.0

    def __post_init__(self):
        if not (isinstance(self.n_elements, (int, np.integer)) and 2 <= self.n_elements <= 400):
            raise ValueError(f"n_elements must be an integer in 2..400, got {self.n_elements!r}")
        if not (self.air_density >= 0 and math.isfinite(self.air_density)):
            raise ValueError(f"air_density must be >= 0, got {self.air_density!r}")
        if not (self.kinematic_viscosity > 0):
            raise ValueError("kinematic_viscosity must be positive")
        if self.tip_mass < 0:
            raise ValueError("tip_mass must not be negative")
        if self.reel.mode == "prescribed":
            L0 = float(np.interp(self.tow.t[0], self.reel.payout_t, self.reel.payout_length))
            if abs(L0 - self.hose.length) > 0.05 * self.hose.length:
                raise ValueError(
                    f"reel payout table starts at {L0:.2f} m but the hose length is {self.hose.length:.2f} m")

    # ---- discretisation --------------------------------------------------------
    @property
    def element_length(self) -> float:
        """Nominal element length, m (the hose outside at the start over N)."""
        return self.hose.length / self.n_elements

    @property
    def has_drogue(self) -> bool:
        return self.drogue is not None

    def nominal_constants(self):
        return self.hose.constants(self.element_length)

    def build_arrays(self, n_hose: int, rest: np.ndarray):
        """Masses and constants for a chain of n_hose elements with rest lengths `rest`
        (hose elements first, the drogue link appended here)."""
        mu = self.hose.mass_per_length
        n = n_hose + 1 + (1 if self.has_drogue else 0)
        ne = n - 1
        rest_all = np.zeros(ne)
        rest_all[:n_hose] = rest
        ka = np.zeros(ne)
        ca = np.zeros(ne)
        kb = np.zeros(n)
        cb = np.zeros(n)
        for e in range(n_hose):
            ka[e], ca[e], _, _ = self.hose.constants(rest[e])
        for j in range(1, n_hose):
            lj = 0.5 * (rest[j - 1] + rest[j])
            _, _, kb[j], cb[j] = self.hose.constants(lj)
        mass = np.zeros(n)
        mass[:n_hose] += 0.5 * mu * rest
        mass[1:n_hose + 1] += 0.5 * mu * rest
        mass[n_hose] += self.tip_mass
        if self.has_drogue:
            d = self.drogue
            rest_all[n_hose] = d.link_length
            mass[n_hose + 1] = d.mass
            # The link is rigid in principle; a spring half as stiff as a hose element
            # (it stretches ~1 mm under the drogue's drag) keeps its numerical mode
            # below the hose's own axial mode, and 5 % of critical damping on the
            # reduced mass keeps it quiet.
            ka[n_hose] = 0.5 * self.nominal_constants()[0]
            m_h = mass[n_hose]
            m_red = m_h * d.mass / (m_h + d.mass)
            ca[n_hose] = 0.1 * math.sqrt(ka[n_hose] * m_red)
        return n, mass, rest_all, ka, ca, kb, cb

    def params(self, n_hose: int, rest: np.ndarray, reel_tension: float = 0.0) -> np.ndarray:
        """The kernel's scalar parameter vector (see `solver.kernel` for the layout)."""
        P = np.zeros(K.NP)
        h = self.hose
        P[K.P_RHO] = self.air_density
        P[K.P_NU] = self.kinematic_viscosity
        P[K.P_GX:K.P_GZ + 1] = self.gravity
        P[K.P_DIAM] = h.outer_diameter
        P[K.P_CA0] = h.ca0
        P[K.P_CDN] = h.cdn
        P[K.P_CDN_REGIMES] = 1.0 if h.cdn_regimes else 0.0
        P[K.P_HOSE_DRAG] = self.hose_drag_scale
        if self.has_drogue:
            d = self.drogue
            P[K.P_HAS_DROGUE] = 1.0
            P[K.P_CDA] = d.drag_area
            P[K.P_CLA] = d.lift_area
            P[K.P_CP_FRAC] = d.cp_aft_of_hinge / d.link_length
            P[K.P_HINGE_FREE] = math.radians(d.free_play_deg)
            P[K.P_HINGE_KPEN] = d.hinge_stop_stiffness
            P[K.P_HINGE_C] = d.hinge_damping
            P[K.P_HINGE_FRIC] = d.hinge_friction
        l = self.element_length
        ka_n, ca_n, kb_n, cb_n = self.nominal_constants()
        if self.clamp is not None:
            dvec = np.asarray(self.clamp.direction, dtype=float)
            dvec = dvec / np.linalg.norm(dvec)
            P[K.P_CLAMP] = 1.0
            P[K.P_CLAMP_DX:K.P_CLAMP_DZ + 1] = dvec
            P[K.P_CLAMP_K] = 2.0 * kb_n * self.clamp.stiffness_factor
            P[K.P_CLAMP_C] = 2.0 * cb_n * self.clamp.stiffness_factor
        if self.end is not None:
            P[K.P_END_MODE] = 1.0
            P[K.P_END_ON] = self.end.t_on
            P[K.P_END_OFF] = self.end.t_off
            P[K.P_END_K] = self.end.stiffness
            P[K.P_END_C] = self.end.damping
        P[K.P_REEL_MODE] = {"locked": 0.0, "prescribed": 1.0, "drum": 2.0}[self.reel.mode]
        P[K.P_MU] = h.mass_per_length
        P[K.P_EA0] = ka_n * l
        P[K.P_ETA_A0] = ca_n * l
        P[K.P_EI1] = kb_n * l
        P[K.P_ETA_B1] = cb_n * l
        P[K.P_L_NOM] = l
        r = self.reel
        P[K.P_DRUM_R0] = r.drum_radius_empty
        P[K.P_DRUM_W] = r.drum_width
        P[K.P_DRUM_I0] = r.drum_inertia_empty
        P[K.P_HOSE_TOTAL] = h.stowed_length
        P[K.P_TORQUE_LAW] = 0.0 if r.torque_law == "constant_torque" else 1.0
        P[K.P_TORQUE] = r.torque if r.torque_law == "constant_torque" else reel_tension
        P[K.P_REEL_HOLD] = r.drive_hold
        P[K.P_REEL_LAG] = r.drive_lag
        P[K.P_VMAX] = 5.0 * self.wind.mean_speed + 100.0
        P[K.P_NE_MIN] = 2
        P[K.P_HOSE_REST_SUM] = float(np.sum(rest[1:n_hose]))
        return P

    def stable_step(self, end_held: Optional[bool] = None) -> float:
        """A leapfrog step inside the stability limit of the stiffest mode.

        The limit of each mode comes from `leapfrog_limit` (the kernel's own
        scheme on x'' = -omega^2 x - gamma x'); the step keeps 80 % of the
        tightest. omega and gamma come from the axial chain's highest mode
        (top eigenvalue of the mass-normalised tridiagonal stiffness of the
        straight chain, drogue link included; the kernel's axial damping is
        implicit and does not limit the step), the zig-zag bending mode
        16 k_b/(m l^2), the hinge stop and the clamp, whichever is tightest.
        With a reel the exit element may shrink to REMESH_MIN element lengths
        (stiffer, shorter levers). With the end held (`end_held`, by default
        whether the model has an end constraint; a host's probe can hold it at
        any time) the chain ends at a fixed node, and the hinge stop swings the
        hose end about the held drogue: a short drogue link makes that mode far
        stiffer than the free one."""
        if end_held is None:
            end_held = self.end is not None
        l = self.element_length
        n_h = self.n_elements
        rest = np.full(n_h, l)
        shrink = 1.0
        if self.reel.mode != "locked":
            rest[0] = K.REMESH_MIN * l
            shrink = K.REMESH_MIN
        n, mass, rest_all, ka, ca, kb, cb = self.build_arrays(n_h, rest)
        m = mass[1:].copy()
        if end_held:
            m[-1] = 1e30     # a node that does not move

        def top_eig(k):
            diag = (k + np.append(k[1:], 0.0)) / m
            off = -k[1:] / np.sqrt(m[:-1] * m[1:])
            return float(eigvalsh_tridiagonal(diag, off, select="i",
                                              select_range=(len(diag) - 1, len(diag) - 1))[0])

        modes = [(math.sqrt(top_eig(ka)), 0.0)]      # (omega, damping rate 2 zeta omega)
        m_node = self.hose.mass_per_length * l
        kb_max = float(np.max(kb)) if n_h > 1 else 0.0
        cb_max = float(np.max(cb)) if n_h > 1 else 0.0
        lever = m_node * (shrink * l) ** 2 * shrink
        modes.append((math.sqrt(16 * kb_max / lever), 16 * cb_max / lever))
        if self.has_drogue:
            d = self.drogue
            inv_i = 1 / (d.mass * d.link_length ** 2) + 1 / (mass[n_h] * l * l)
            modes.append((math.sqrt(d.hinge_stop_stiffness * inv_i), d.hinge_damping * inv_i))
            if end_held:
                # the hose end moving by x turns the hinge by x (1/link + 1/l)
                inv_i = (1 / d.link_length + 1 / l) ** 2 / mass[n_h]
                modes.append((math.sqrt(d.hinge_stop_stiffness * inv_i), d.hinge_damping * inv_i))
        if self.end is not None and self.end.stiffness > 0:
            m_end = mass[-1]
            modes.append((math.sqrt(self.end.stiffness / m_end), self.end.damping / m_end))
        if self.clamp is not None:
            ik = 1 / (0.5 * m_node * (0.5 * l) ** 2)
            modes.append((math.sqrt(2 * kb_max * self.clamp.stiffness_factor * ik),
                          2 * cb_max * self.clamp.stiffness_factor * ik))
        return 0.8 * min(leapfrog_limit(omega, rate) for omega, rate in modes if omega > 0)


def _amplification(omega: float, gamma: float, dt) -> np.ndarray:
    """Spectral radius of one kernel step on x'' = -omega^2 x - gamma x', for each
    step in `dt` (a number or an array).

    The kernel's state is (x, v at the half step, previous acceleration); the
    damping sees v_half + a_prev dt/2 (see `solver.kernel.run_steps`)."""
    w2, g = omega * omega, gamma
    h = np.atleast_1d(np.asarray(dt, dtype=float))
    # a = -w2 x - g (v + h/2 a_prev);  v' = v + h a;  x' = x + h v';  a_prev' = a
    M = np.zeros((len(h), 3, 3))
    M[:, 2] = np.stack([np.full_like(h, -w2), np.full_like(h, -g), -g * h / 2], axis=1)
    M[:, 1] = h[:, None] * M[:, 2]
    M[:, 1, 1] += 1.0
    M[:, 0] = h[:, None] * M[:, 1]
    M[:, 0, 0] += 1.0
    return np.max(np.abs(np.linalg.eigvals(M)), axis=1)


def leapfrog_limit(omega: float, gamma: float) -> float:
    """Largest step (s) at which the kernel's scheme is stable for a mode of
    circular frequency omega (rad/s) and damping rate gamma = 2 zeta omega (1/s).

    Undamped, it is the leapfrog's 2 / omega. Damped, the stable steps from zero
    form one interval, found by refining a grid of 16 steps eight times (2e-10 of
    2 / omega: every call to `simulate` pays for this, a bisection's sixty
    eigenvalue problems cost more than a short run)."""
    if gamma == 0.0:
        return 2.0 / omega
    lo, hi = 0.0, 2.0 / omega
    for _ in range(8):
        grid = np.linspace(lo, hi, 17)[1:]
        unstable = _amplification(omega, gamma, grid) > 1.0 + 1e-12
        if not unstable.any():
            return float(hi)
        k = int(np.argmax(unstable))
        lo, hi = (grid[k - 1] if k > 0 else lo), grid[k]
    return float(lo)
