"""The host-simulator step API: advance a `Model` one frame at a time.

A flight simulator owns time. Each frame (60 or 120 Hz, or whatever it runs
at) it moves the tanker and the receiver to the end of the frame, then asks
the hose where it is and what it pulls with:

    stepper = Stepper(model)                        # static trail at the start
    out = stepper.step(1 / 60, tow_point_state, probe_state)
    out.tow_force, out.probe_force, out.drogue_xyz, out.hose_xyz, ...

`tow_point_state` is the tow point's position and velocity at the END of the
frame, six numbers (x y z vx vy vz, or a (position, velocity) pair) in the
model's tow-point frame (x aft along the free stream, z up, m and m/s), the
frame the wind field is given in. `probe_state` is None while the drogue flies
free and the probe tip's position and velocity at the end of the frame while
the drogue is on the probe: the drogue's centre of mass then follows it (the
model's `EndConstraint`, driven by the host instead of a table; its stiffness
and damping, when the model gives them, make the coupling compliant). Between
the previous frame's states and these, the stepper moves both points along the
cubic Hermite curve through positions and velocities; a new rigid contact
starts from where the drogue is, so capture is continuous.

Inside a frame the compiled kernel takes as many equal sub-steps as keep it
below the model's stable step with the drogue held (`Model.stable_step`), so
any frame rate is stable; the reel (locked, drum with its torque law, or a
prescribed payout in absolute time) and its remeshing run as in
`solver.integrate.simulate`, which a stepper driven with the same inputs
reproduces. A frame is one compiled call unless the reel remeshes inside it.
A stepper allocates its buffers once: memory does not grow with the length of
the run.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np
from numba import njit

from solver import kernel as K
from solver.chain import check_failure, node_capacity, reel_set_point, reel_state, remesh, tables
from solver.model import Model
from solver.state import State
from solver.statics import solve_static


@dataclass
class StepOutput:
    """The hose at the end of a frame (tow-point frame, SI units).

    tow_force: force the hose applies to the tow point (N), and
    probe_force: force the drogue applies to the probe (N), zero while free,
        are means over the frame (impulse / dt): what a host applies to its
        bodies over its frame, with the momentum the hose really exchanged and
        none of the axial ringing (hundreds of Hz) that a sample would alias.
    tension: axial force of each hose element at the end of the frame, tow end
        first (N)."""

    t: float
    hose_xyz: np.ndarray
    hose_vel: np.ndarray
    drogue_xyz: Optional[np.ndarray]
    drogue_vel: Optional[np.ndarray]
    tension: np.ndarray
    tow_force: np.ndarray
    probe_force: np.ndarray
    reel_length: float
    reel_speed: float
    reel_exit_tension: float
    attached: bool
    substeps: int
    substep_s: float


def _point_state(x, what: str) -> np.ndarray:
    a = np.array(x, dtype=float).reshape(-1)
    if a.shape != (6,):
        raise ValueError(f"{what} needs position and velocity, six numbers; got shape {np.shape(x)}")
    if not math.isfinite(a.sum()):    # a NaN or an infinity anywhere reaches the sum
        raise ValueError(f"{what} holds non-finite values: {a}")
    return a


@njit(cache=True)
def _hermite_table(a, b, dt, n_sub, out):
    """Rows x y z vx vy vz at the n_sub + 1 sub-step times of a frame, on the cubic
    Hermite curve from state a (position, velocity) to state b over dt."""
    for k in range(n_sub + 1):
        s = k / n_sub
        s2 = s * s
        s3 = s2 * s
        h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, -2 * s3 + 3 * s2, s3 - s2
        d00, d10, d01, d11 = 6 * s2 - 6 * s, 3 * s2 - 4 * s + 1, -6 * s2 + 6 * s, 3 * s2 - 2 * s
        for c in range(3):
            p0, v0, p1, v1 = a[c], a[3 + c] * dt, b[c], b[3 + c] * dt
            out[k, c] = h00 * p0 + h10 * v0 + h01 * p1 + h11 * v1
            out[k, 3 + c] = (d00 * p0 + d10 * v0 + d01 * p1 + d11 * v1) / dt


@njit(cache=True)
def _frame(t_start, dt, h, n_sub, done, P, n, nh, pos, vel_half, acc, mass, rest, ka, ca, kb, cb, wind,
           tow0, tow1, held, probe0, probe1, tow_tab, end_tab, reel_t0, reel_dt, reel_tab, reel,
           out_t, out_pos, out_vel, out_ten, out_reel, out_end, out_energy, out_mom, work, end_reaction,
           impulse0, vel, F, tension, scratch, loads):
    """One frame in one compiled call (the host's frame rate makes the per-call
    overhead count): the frame's path tables (when `done` is 0), the kernel's
    sub-steps from `done` on, and, when they all ran, the frame-end velocities,
    forces and tensions and the mean loads over the frame (loads[0:3] on the tow
    point, loads[3:6] on the probe). Returns the kernel's (code, steps, bad node);
    the caller remeshes and calls again for the rest of the frame.

    The kernel sets the reel-exit element's rest length and constants at the
    start of each step, so after a frame they still belong to its last step; the
    element is stiff enough that the difference (reel speed x sub-step) would
    show in its tension: the frame-end forces bring them up to date, on copies."""
    if done == 0:
        _hermite_table(tow0, tow1, dt, n_sub, tow_tab)
        if held:
            _hermite_table(probe0, probe1, dt, n_sub, end_tab)
        for c in range(3):
            impulse0[c] = reel[7 + c]
            impulse0[3 + c] = end_reaction[3 + c]
    code, steps, _, bad = K.run_steps(
        t_start + done * h, h, n_sub - done, 1, 0, P, n, nh, pos, vel_half, acc, mass, rest, ka, ca, kb, cb, wind,
        t_start, h, tow_tab, t_start, h, end_tab, reel_t0, reel_dt, reel_tab, reel,
        out_t, out_pos, out_vel, out_ten, out_reel, out_end, out_energy, out_mom, 1, work, end_reaction)
    if code != K.OK:
        return code, steps, bad
    t = t_start + dt
    for i in range(n):
        for c in range(3):
            vel[i, c] = vel_half[i, c] + 0.5 * h * acc[i, c]
    rigid = held and P[K.P_END_K] == 0.0
    for c in range(3):
        vel[0, c] = tow1[3 + c]
        if rigid:
            vel[n - 1, c] = probe1[3 + c]
        loads[c] = (reel[7 + c] - impulse0[c]) / dt
        loads[3 + c] = -(end_reaction[3 + c] - impulse0[3 + c]) / dt if held else 0.0
    mode = P[K.P_REEL_MODE]
    if mode == 0.0:
        K.compute_forces(t, P, n, nh, pos, vel, mass, rest, ka, ca, kb, cb, wind, F, tension, work)
        return code, steps, bad
    if mode == 1.0:
        row = np.empty(2)
        K._interp_table(reel_t0, reel_dt, reel_tab, t, row)
        L = row[0]
    else:
        L = reel[0]
    ne = n - 1
    r2, ka2, ca2, kb2, cb2 = scratch[0, :ne], scratch[1, :ne], scratch[2, :ne], scratch[3, :n], scratch[4, :n]
    r2[:] = rest[:ne]
    ka2[:] = ka[:ne]
    ca2[:] = ca[:ne]
    kb2[:] = kb[:n]
    cb2[:] = cb[:n]
    r0 = L - P[K.P_HOSE_REST_SUM]
    r2[0] = r0
    ka2[0] = P[K.P_EA0] / r0
    ca2[0] = P[K.P_ETA_A0] / r0
    if nh > 1:
        lj = 0.5 * (r0 + r2[1])
        kb2[1] = P[K.P_EI1] / lj
        cb2[1] = P[K.P_ETA_B1] / lj
    K.compute_forces(t, P, n, nh, pos, vel, mass, r2, ka2, ca2, kb2, cb2, wind, F, tension, work)
    return code, steps, bad


class Stepper:
    """Frame-by-frame integration of `model` for a host simulator (see the module doc)."""

    def __init__(self, model: Model, state0: Optional[State] = None, t0: Optional[float] = None):
        if t0 is None:
            t0 = state0.t if state0 is not None else float(model.tow.t[0])
        if state0 is None:
            state0 = solve_static(model, t0)
        self.model = model
        self.t = float(t0)
        # the host's probe may hold the drogue at any frame
        self.dt_stable = model.stable_step(end_held=model.has_drogue or model.end is not None)
        self._wind = model.wind.params
        r = model.reel
        t_tab = float(r.payout_t[-1]) if r.mode == "prescribed" else self.t + 1.0
        self._reel_tab = tables(model, max(t_tab, self.t + 1.0))[6:9]
        nh = state0.n_hose
        self._n_max = node_capacity(model, nh)
        self._rest = state0.rest.copy()
        self._reel_tension = reel_set_point(model, state0, self._rest)
        self._build(nh)
        self.pos = np.ascontiguousarray(state0.pos, dtype=float).copy()
        vel = np.ascontiguousarray(state0.vel, dtype=float).copy()
        # the reel drive's dead-time ring counts sub-steps: sized again once the first
        # frame fixes the sub-step
        self.reel = reel_state(model, state0, self.dt_stable)
        self.end_reaction = np.zeros(6)     # the kernel's reaction and its cumulative impulse
        self._work = np.zeros((6, self._n_max, 3))
        self._F = np.zeros((self._n_max, 3))
        self._ten = np.zeros(self._n_max)
        # the kernel records nothing here: one-row outputs, already "full"
        self._out_t = np.zeros(1)
        self._out_pos = np.zeros((1, self._n_max, 3))
        self._out_vel = np.zeros((1, self._n_max, 3))
        self._out_ten = np.zeros((1, self._n_max))
        self._out_reel = np.zeros((1, 6))
        self._out_end = np.zeros((1, 3))
        self._out_energy = np.zeros((1, 2))
        self._out_mom = np.zeros((1, 11))
        self._tow_tab = np.zeros((2, 6))
        self._scratch = np.zeros((5, self._n_max))
        self._impulse0 = np.zeros(6)
        self._loads = np.zeros(6)
        self._end_tab = np.zeros((2, 6))
        # accelerations at the start, for the leapfrog's half-step velocities
        F = self._forces(self.t, self.pos, vel)
        self.acc = F / self.mass[:, None]
        self.acc[0] = 0.0
        self._v_full = vel            # the full-step velocity until the first frame fixes h
        self.vel_half = None
        self._h = None
        self._tow = np.concatenate([self.pos[0], vel[0]])
        self._probe = None

    # ---- arrays for the current element count ---------------------------------------
    def _build(self, nh: int):
        self.nh = nh
        self.n, self.mass, self._rest_all, self._ka, self._ca, self._kb, self._cb = \
            self.model.build_arrays(nh, self._rest)
        self.P = self.model.params(nh, self._rest, self._reel_tension)
        # contact comes from the host's probe states, not from the model's table
        self.P[K.P_END_MODE] = 0.0
        self.P[K.P_END_ON] = -math.inf
        self.P[K.P_END_OFF] = math.inf

    def _forces(self, t, pos, vel):
        n = self.n
        F = self._F[:n]
        K.compute_forces(t, self.P, n, self.nh, pos, vel, self.mass, self._rest_all, self._ka, self._ca,
                         self._kb, self._cb, self._wind, F, self._ten[:n], self._work)
        return F

    # ---- the API ---------------------------------------------------------------------
    @property
    def state(self) -> State:
        """The current state (positions and full-step velocities), a copy."""
        return State(self.t, self.pos.copy(), self._full_velocity(), self._rest.copy(),
                     float(self.reel[0]), float(self.reel[1]))

    def _full_velocity(self) -> np.ndarray:
        if self.vel_half is None:
            return self._v_full.copy()
        v = self.vel_half + 0.5 * self._h * self.acc
        v[0] = self._tow[3:]
        if self._probe is not None and self.P[K.P_END_K] == 0.0:
            v[-1] = self._probe[3:]
        return v

    def step(self, dt: float, tow_point_state, probe_state=None) -> StepOutput:
        """Advance one host frame of `dt` seconds to the given end-of-frame states."""
        dt = float(dt)
        if not (dt > 0 and math.isfinite(dt)):
            raise ValueError(f"frame step must be positive and finite, got {dt!r}")
        tow1 = _point_state(tow_point_state, "tow_point_state")
        probe1 = None if probe_state is None else _point_state(probe_state, "probe_state")
        if probe1 is not None and not self.model.has_drogue:
            raise ValueError("probe_state given but the model has no drogue")
        n_sub = max(1, math.ceil(dt / self.dt_stable - 1e-9))
        h = dt / n_sub
        if self._h != h:
            # keep the full-step velocity, restart the half step for the new sub-step
            v = self._full_velocity()
            self.vel_half = v - 0.5 * h * self.acc
            self._h = h
            self._resize_reel(h)
        held = probe1 is not None
        if held:
            self.P[K.P_END_MODE] = 1.0
            if self._probe is not None:
                probe0 = self._probe
            elif self.P[K.P_END_K] == 0.0:
                # a new rigid contact starts from where the drogue is
                probe0 = np.concatenate([self.pos[-1], self._full_velocity()[-1]])
            else:
                # a compliant coupling (the model's EndConstraint stiffness) meets the
                # probe where it came from, and its spring takes up the difference
                probe0 = np.concatenate([probe1[:3] - dt * probe1[3:], probe1[3:]])
            if self._end_tab.shape[0] != n_sub + 1:
                self._end_tab = np.empty((n_sub + 1, 6))
        else:
            self.P[K.P_END_MODE] = 0.0
            probe0 = probe1 = tow1
        if self._tow_tab.shape[0] != n_sub + 1:
            self._tow_tab = np.empty((n_sub + 1, 6))
        t_start = self.t
        done = 0
        while True:
            n = self.n
            vel = np.empty((n, 3))
            code, steps, bad = _frame(
                t_start, dt, h, n_sub, done, self.P, n, self.nh, self.pos, self.vel_half, self.acc,
                self.mass, self._rest_all, self._ka, self._ca, self._kb, self._cb, self._wind,
                self._tow, tow1, held, probe0, probe1, self._tow_tab, self._end_tab, *self._reel_tab, self.reel,
                self._out_t, self._out_pos, self._out_vel, self._out_ten, self._out_reel, self._out_end,
                self._out_energy, self._out_mom, self._work, self.end_reaction, self._impulse0, vel,
                self._F[:n], self._ten[:n], self._scratch, self._loads)
            done += steps
            if code == K.OK:
                break
            check_failure(code, t_start + done * h, self.model, self.n, bad, self.P, "step")
            self.pos, self.vel_half, self.acc, self._rest, dflux = remesh(
                code, self.model, self.nh, self.pos, self.vel_half, self.acc, self._rest, self.mass, self.reel[0])
            self.reel[4:7] += dflux
            self._build(len(self._rest))
            self.P[K.P_END_MODE] = 1.0 if held else 0.0
        self.t = t_start + dt
        self._tow = tow1
        self._probe = probe1 if held else None
        nh = self.nh
        drogue = self.model.has_drogue
        loads = self._loads
        return StepOutput(
            t=self.t,
            hose_xyz=self.pos[:nh + 1].copy(), hose_vel=vel[:nh + 1],
            drogue_xyz=self.pos[nh + 1].copy() if drogue else None,
            drogue_vel=vel[nh + 1] if drogue else None,
            tension=self._ten[:nh].copy(), tow_force=loads[:3].copy(), probe_force=loads[3:].copy(),
            reel_length=float(self.reel[0]), reel_speed=float(self.reel[1]),
            reel_exit_tension=float(self._ten[0]), attached=held, substeps=n_sub, substep_s=h)

    def _resize_reel(self, h: float):
        """The kernel's reel array for sub-step h: the bookkeeping sums and the drive's
        lagged speed carry over; its dead-time ring restarts full of the current speed."""
        old = self.reel
        st = State(self.t, self.pos, self.pos, self._rest, float(old[0]), float(old[1]))
        new = reel_state(self.model, st, h)
        keep = min(K.REEL_RING_POS, len(old), len(new))
        new[:keep] = old[:keep]
        self.reel = new
