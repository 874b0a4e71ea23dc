"""Cross-code check and speed race against MoorDyn on one towed hose and drogue.

    python3 benchmarks/peer_moordyn.py [--elements 20] [--json] [--skip-engagement]

Needs MoorDyn-C's Python package (`pip install -e .[peer]`, i.e. moordyn>=2).

The case: a 75 ft hose, 3 in outer diameter, 4.0 kg/m, EA 2.0e6 N, EI 50 N m^2,
crossflow Cd 1.2 and skin friction 0.004 on the wetted area, axial damping
300 N s (no bending damping: MoorDyn has none); a 30 kg drogue with isotropic
drag area 0.6 m^2 and no lift; air 0.77 kg/m^3 at 130 m/s relative wind. Static
trail, then the tow point moves z = 0.3 sin(pi t) m for 4 s and stops where it
started (released); the drogue rings down freely.

How MoorDyn is made to fly the same hose:
- MoorDyn's water surface is at z = 0 and it drops the fluid loads above it, so
  the tow point sits at z = -1000 m in 5000 m of "water" of density 0.77; every
  position is reported relative to the tow point.
- The relative wind is a uniform 130 m/s current (Currents = 1,
  current_profile.txt).
- MoorDyn always subtracts buoyancy of the fluid density (rho A g per metre);
  its line mass is raised by rho A = 0.0035 kg/m so that the weight matches.
  That also adds 0.09 % to its line inertia (no added mass: Ca = CaAx = 0).
- Its initial-condition solvers ignore currents, so MoorDyn starts without them
  (Init_NoIC) and settles dynamically with the tow point held until the drogue
  moves less than 1e-5 m in 2 s; ours solves the statics by Newton.
- MoorDyn's drogue is a point (mass, isotropic CdA) on the hose end. Ours is a
  2 cm link on a free hinge (+/-80 deg, never reached) with its drag at its
  centre of mass, which is a point mass with isotropic drag 2 cm behind the
  hose end (2.45 cm: the link's spring gives 4.5 mm to the 3.9 kN of drag at
  20 elements, half that at 40). Our drogue position is that of the drogue's
  centre of mass; the hose end (hinge) is printed too.
- A coupled point in MoorDyn moves from the position given at the start of each
  coupling step with the velocity given; the script passes the exact tow
  motion and velocity every 10 ms.

Free response: a damped cosine (plus offset) fitted by least squares to the
drogue's height from 0.5 s after the tow point stops to the end of the run. The
ring-down also carries the waves that run along the hose, so one mode explains
most but not all of it; the fit's RMS residual is printed, and both codes go
through the same fit.

Convergence: each code runs at the chosen element count and step, then with the
step halved, then with twice the elements; the script prints the largest change
of every figure. Our step is the solver's stable step (80 % of the kernel's
stability limit, its own at twice the elements). MoorDyn's is found the same
way: bisection on the largest step (RK2, its default scheme) at which the trail
settles from MoorDyn's initial shape, times 0.8; at twice the elements it runs
at half that step.

Speed: the wall time of the 16 s dynamic run (forced motion and ring-down),
best of five, the same records (every 10 ms) taken from both, both at their
converged settings. MoorDyn runs from its serialized settled state each time.

Also measured here (ours only): the 40-element 3D engagement case (KDC-10 pod
hose full of fuel, 254 KCAS at 15 000 ft, 2 m/s side wind; probe contact at
2 s pushes the drogue 1.5 m forward and 0.3 m sideways while the reel takes up
1.5 m; back out and disconnect at 22 s; 30 s) through `simulate` and through
the host step API at 60 and 120 Hz (best of seven), and the step API's traced
memory over a 10-minute run.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import platform
import sys
import tempfile
import time
import tracemalloc
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from solver import kernel as K  # noqa: E402
from solver.atmosphere import isa, kcas_to_tas  # noqa: E402
from solver.drogue import DrogueProperties  # noqa: E402
from solver.hose import HoseProperties  # noqa: E402
from solver.integrate import simulate  # noqa: E402
from solver.model import EndConstraint, Model, Trajectory  # noqa: E402
from solver.reel import ReelProperties  # noqa: E402
from solver.statics import solve_static  # noqa: E402
from solver.units import FT, G0  # noqa: E402
from solver.wind import freestream, uniform  # noqa: E402


@dataclass(frozen=True)
class PeerCase:
    length: float = 75 * FT
    diameter: float = 3 * 0.0254
    mass_per_length: float = 4.0
    EA: float = 2.0e6
    EI: float = 50.0
    axial_damping: float = 300.0     # N s: BA in MoorDyn, eta_a here
    cdn: float = 1.2
    ca0: float = 0.004
    drogue_mass: float = 30.0
    drogue_cda: float = 0.6
    rho: float = 0.77
    nu: float = 1.5e-5               # only used by Reynolds-number regimes, which are off
    wind: float = 130.0
    amplitude: float = 0.3
    forced_s: float = 4.0
    run_s: float = 16.0
    record_dt: float = 0.01
    depth: float = 1000.0            # tow point depth in MoorDyn's "water"
    link: float = 0.02               # our drogue link, m


CASE = PeerCase()


# ---- pure helpers (no MoorDyn needed) ----------------------------------------------
def tow_motion(t, case: PeerCase = CASE):
    """Tow point height and vertical speed: 0.3 sin(pi t) for 0 <= t < 4 s, then held at 0."""
    t = np.asarray(t, dtype=float)
    on = (t >= 0) & (t < case.forced_s)
    w = math.pi
    z = np.where(on, case.amplitude * np.sin(w * t), 0.0)
    vz = np.where(on, case.amplitude * w * np.cos(w * t), 0.0)
    return z, vz


def end_angles_deg(points) -> tuple[float, float]:
    """Angles below the horizontal (deg) of the first and last element of a node chain
    (rows x, y, z; z up)."""
    p = np.asarray(points, dtype=float)
    out = []
    for a, b in ((p[0], p[1]), (p[-2], p[-1])):
        d = b - a
        out.append(math.degrees(math.atan2(-d[2], math.hypot(d[0], d[1]))))
    return out[0], out[1]


def damped_fit(t, y):
    """Least-squares fit of y ~ c + A exp(-zeta w t) cos(w sqrt(1 - zeta^2) t + phi).

    The start values come from the mean-crossing period and the decay of successive
    peak magnitudes, so the fit settles on the dominant mode. Returns (f_hz, zeta,
    rms residual / rms signal)."""
    t = np.asarray(t, dtype=float) - float(t[0])
    y = np.asarray(y, dtype=float)
    z = y - y.mean()
    s = np.where(np.sign(z[:-1]) != np.sign(z[1:]))[0]
    if len(s) < 3:
        raise ValueError("free response has fewer than three mean crossings")
    tc = t[s] - z[s] * (t[s + 1] - t[s]) / (z[s + 1] - z[s])
    wd0 = math.pi / float(np.mean(np.diff(tc)))
    peaks = [np.max(np.abs(z[s[i]:s[i + 1] + 1])) for i in range(len(s) - 1)]
    ratio = float(np.clip(np.median(np.array(peaks[1:]) / np.array(peaks[:-1])), 1e-3, 0.999))
    zeta0 = min(0.9, -math.log(ratio) / math.pi / math.sqrt(1 + (math.log(ratio) / math.pi) ** 2))
    A0 = float(np.max(np.abs(z)))
    i0 = int(np.argmax(np.abs(z[:max(3, s[1])])))
    phi0 = -wd0 * t[i0] + (0.0 if z[i0] > 0 else math.pi)

    def model(p):
        c, A, w, zeta, phi = p
        return c + A * np.exp(-zeta * w * t) * np.cos(w * math.sqrt(max(1 - zeta * zeta, 1e-12)) * t + phi)

    best = None
    for phase in (phi0, phi0 + math.pi / 2, phi0 - math.pi / 2):
        p0 = [float(y.mean()), A0, wd0 / math.sqrt(1 - zeta0 ** 2), zeta0, phase]
        r = least_squares(lambda p: model(p) - y, p0,
                          bounds=([-np.inf, 0.0, 0.2 * wd0, 0.0, -np.inf], [np.inf, np.inf, 5 * wd0, 0.95, np.inf]))
        if best is None or r.cost < best.cost:
            best = r
    c, A, w, zeta, phi = best.x
    rel = float(np.sqrt(np.mean(best.fun ** 2)) / max(np.sqrt(np.mean(z ** 2)), 1e-300))
    return w / (2 * math.pi), float(zeta), rel


def free_response(t, z, case: PeerCase = CASE):
    """Frequency (Hz), damping ratio and relative fit residual of the drogue's ring-down
    after the tow point stops.

    The first 0.5 s after the stop is left out: the tow point's own stop takes about
    as long to travel down the hose."""
    t = np.asarray(t)
    keep = t >= case.forced_s + 0.5
    return damped_fit(t[keep], np.asarray(z)[keep])


def moordyn_input(n: int, dt: float, scheme: str = "RK2", case: PeerCase = CASE) -> str:
    """MoorDyn-C v2 input file for the peer case (tow point coupled, drogue free)."""
    c = case
    area = math.pi / 4 * c.diameter ** 2
    w_line = c.mass_per_length + c.rho * area     # MoorDyn subtracts rho A g
    z0 = -c.depth
    line_type = f"hose  {c.diameter!r}  {w_line!r}  {c.EA!r}  {c.axial_damping!r}  {c.EI!r}  {c.cdn!r}  0.0  " \
                f"{c.ca0!r}  0.0"
    # the drogue starts near its trail; MoorDyn settles it
    drogue = f"2     Free       {0.99 * c.length!r}  0.0  {z0 - 0.15 * c.length!r}  {c.drogue_mass!r}  0.0  " \
             f"{c.drogue_cda!r}  0.0"
    return f"""--------------------- MoorDyn Input File ------------------------------------
Towed refueling hose and drogue (workbench peer check); fluid = air at {c.rho} kg/m^3
---------------------- LINE TYPES ------------------------------------------------------
TypeName   Diam    Mass/m     EA     BA/-zeta    EI      Cd     Ca     CdAx    CaAx
(name)     (m)     (kg/m)     (N)    (N-s/-)    (N-m^2)  (-)    (-)    (-)     (-)
{line_type}
---------------------- POINTS ---------------------------------------------------------
ID   Attachment  X       Y     Z      Mass   Volume  CdA    Ca
(#)   (word/ID)  (m)     (m)   (m)    (kg)   (m^3)   (m^2)  (-)
1     Coupled    0.0     0.0   {z0!r}   0.0    0.0     0.0    0.0
{drogue}
---------------------- LINES -----------------------------------------------------------
ID   LineType   AttachA  AttachB  UnstrLen  NumSegs  LineOutputs
(#)   (name)     (ID)     (ID)      (m)       (-)      (-)
1     hose       1        2        {c.length!r}   {n}   -
---------------------- OPTIONS ---------------------------------------------------------
{dt!r}     dtM
{scheme}   tScheme
{G0!r}    g
{c.rho!r}    rho
{5 * c.depth!r}    WtrDpth
1          Currents
0          writeLog
1          disableOutput
1          disableOutTime
------------------------- need this line -----------------------------------------------
"""


def current_profile(case: PeerCase = CASE) -> str:
    return ("--------------------- MoorDyn steady currents File -----------------------\n"
            "uniform relative wind\nz (m), ux (m/s), uy (m/s), uz (m/s)\n"
            f"{-10 * case.depth!r} {case.wind!r} 0.0 0.0\n0.0 {case.wind!r} 0.0 0.0\n")


def metrics(t, drogue_xyz, hose_nodes_static, drogue_static, tow_force_static, case: PeerCase = CASE):
    """The compared figures from one run (positions relative to the tow point)."""
    z = np.asarray(drogue_xyz)[:, 2] - drogue_static[2]
    f, zeta, resid = free_response(t, z, case)
    a_tow, a_end = end_angles_deg(hose_nodes_static)
    return {
        "drogue_x_m": float(drogue_static[0]),
        "drogue_z_m": float(drogue_static[2]),
        "angle_tow_end_deg": a_tow,
        "angle_drogue_end_deg": a_end,
        "tow_force_N": float(np.linalg.norm(tow_force_static)),
        "tow_force_x_N": float(tow_force_static[0]),
        "tow_force_z_N": float(tow_force_static[2]),
        "frequency_hz": f,
        "damping_ratio": zeta,
        "fit_residual": resid,
    }


# ---- our solver ---------------------------------------------------------------------
def our_model(n: int, case: PeerCase = CASE) -> Model:
    hose = HoseProperties(length=case.length, outer_diameter=case.diameter, inner_diameter=0.0,
                          dry_mass_per_length=case.mass_per_length, EI=case.EI, EA=case.EA,
                          axial_damping=case.axial_damping, bending_damping=0.0,
                          cdn=case.cdn, cdn_regimes=False, ca0=case.ca0)
    # cd 1 on a reference area of 0.6 m^2; drag at the centre of mass on a short free link
    drogue = DrogueProperties(mass=case.drogue_mass, diameter=math.sqrt(4 * case.drogue_cda / math.pi), cd=1.0,
                              cl=0.0, cp_aft_of_hinge=case.link, cg_aft_of_hinge=case.link, free_play_deg=80.0,
                              hinge_stop_stiffness=5.0e3)
    t = np.arange(0.0, case.forced_s + 1e-9, 0.001)
    z, _ = tow_motion(t, case)
    z[-1] = 0.0
    tt = np.append(t, case.run_s + 1.0)
    tow = Trajectory(tt, np.column_stack([np.zeros_like(tt), np.zeros_like(tt), np.append(z, 0.0)]))
    return Model(hose, n, case.rho, case.nu, wind=freestream(case.wind), drogue=drogue, tow=tow)


def run_ours(n: int, dt: float | None = None, repeat: int = 5, case: PeerCase = CASE) -> dict:
    m = our_model(n, case)
    s0 = solve_static(m)
    res = simulate(m, 0.2, s0, dt=dt, record_dt=case.record_dt)      # loads the compiled kernel
    wall = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = simulate(m, case.run_s, s0, dt=dt, record_dt=case.record_dt)
        wall = min(wall, time.perf_counter() - t0)
    out = metrics(res.t, res.drogue_xyz, s0.pos[:-1], s0.pos[-1], static_tow_force(m, s0), case)
    out.update(elements=n, dt_s=res.dt, wall_s=wall, rtf=case.run_s / wall,
               hose_end_x_m=float(s0.pos[-2, 0]), hose_end_z_m=float(s0.pos[-2, 2]))
    return out


def static_tow_force(m: Model, s0) -> np.ndarray:
    """The hose's force on the tow point in the static trail (the first record of a run
    already sees the tow point moving, whose axial damping adds ~50 N)."""
    n, mass, rest, ka, ca, kb, cb = m.build_arrays(s0.n_hose, s0.rest)
    F = np.zeros((n, 3))
    K.compute_forces(0.0, m.params(s0.n_hose, s0.rest), n, s0.n_hose, s0.pos, np.zeros_like(s0.pos), mass, rest,
                     ka, ca, kb, cb, m.wind.params, F, np.zeros(n), np.zeros((6, n, 3)))
    return F[0]


# ---- MoorDyn -----------------------------------------------------------------------
@contextlib.contextmanager
def _quiet():
    """MoorDyn-C prints its set-up and errors from C++; keep them off the report."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)
    os.dup2(null, 2)
    try:
        yield
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, null):
            os.close(fd)


class MoorDynHose:
    """The peer case in MoorDyn-C: create, settle, and run the forced motion."""

    def __init__(self, n: int, dt: float, scheme: str = "RK2", case: PeerCase = CASE):
        import moordyn
        self.md = moordyn
        self.n, self.dt, self.case = n, dt, case
        self.z0 = -case.depth
        self._dir = tempfile.TemporaryDirectory()
        path = Path(self._dir.name) / "hose.txt"
        path.write_text(moordyn_input(n, dt, scheme, case))
        (Path(self._dir.name) / "current_profile.txt").write_text(current_profile(case))
        with _quiet():
            self.sys = moordyn.Create(str(path))
            moordyn.Init_NoIC(self.sys, [0.0, 0.0, self.z0], [0.0, 0.0, 0.0])
        self.line = moordyn.GetLine(self.sys, 1)
        self.drogue = moordyn.GetPoint(self.sys, 2)
        self.t = 0.0
        self.force = np.zeros(3)

    def close(self):
        self.md.Close(self.sys)
        self._dir.cleanup()

    def _step(self, z, vz, dtc):
        with _quiet():      # a blow-up is reported by an exception; its node dump is noise
            f = self.md.Step(self.sys, [0.0, 0.0, self.z0 + z], [0.0, 0.0, vz], self.t, dtc)
        self.t += dtc
        self.force = np.asarray(f, dtype=float)

    def drogue_pos(self) -> np.ndarray:
        return np.asarray(self.md.GetPointPos(self.drogue)) - [0.0, 0.0, self.z0]

    def nodes(self) -> np.ndarray:
        return np.array([self.md.GetLineNodePos(self.line, i) for i in range(self.n + 1)]) - [0.0, 0.0, self.z0]

    def settle(self, tol=1e-5, window=2.0, t_max=300.0, dtc=0.05) -> float:
        """Hold the tow point until the drogue moves less than `tol` m over `window` s."""
        prev = self.drogue_pos()
        while self.t < t_max:
            for _ in range(int(round(window / dtc))):
                self._step(0.0, 0.0, dtc)
            p = self.drogue_pos()
            if np.max(np.abs(p - prev)) < tol:
                return self.t
            prev = p
        raise RuntimeError(f"MoorDyn did not settle in {t_max} s")

    def forced(self, t_end: float, dtc: float) -> tuple[np.ndarray, np.ndarray]:
        """Run the tow motion from t = 0 to t_end; drogue positions every dtc (time, xyz)."""
        nrec = int(round(t_end / dtc))
        ts = np.arange(nrec) * dtc
        z, vz = tow_motion(ts, self.case)
        out = np.empty((nrec + 1, 3))
        out[0] = self.drogue_pos()
        t_local = self.t
        for k in range(nrec):
            self._step(float(z[k]), float(vz[k]), dtc)
            out[k + 1] = self.drogue_pos()
        self.t = t_local + nrec * dtc
        return np.arange(nrec + 1) * dtc, out


def moordyn_stable_dt(n: int, lo: float, hi: float, case: PeerCase = CASE, iters: int = 6) -> float:
    """Largest MoorDyn step (bisection between lo, good, and hi, bad) at which the trail
    settles from MoorDyn's initial shape: the drogue moving less than 1e-5 m in 2 s
    within 120 s. Settling, not merely not blowing up: near its limit RK2 lets the
    stiff axial modes ring on (a millimetre at 0.8 of the blow-up step, measured)."""
    def settles(dt):
        h = MoorDynHose(n, dt, case=case)
        try:
            h.settle(t_max=120.0)
            return True
        except Exception:   # not settled, or MoorDyn raised on a NaN
            return False
        finally:
            h.close()

    if not settles(lo):
        raise RuntimeError(f"MoorDyn does not settle at the lower bracket dt={lo}")
    for _ in range(iters):
        mid = math.sqrt(lo * hi)
        if settles(mid):
            lo = mid
        else:
            hi = mid
    return lo


def run_moordyn(n: int, dt: float, repeat: int = 5, case: PeerCase = CASE) -> dict:
    h = MoorDynHose(n, dt, case=case)
    t_settle = h.settle()
    nodes = h.nodes()
    drogue0 = h.drogue_pos()
    force0 = h.force.copy()
    settled = h.md.Serialize(h.sys)
    wall = math.inf
    for _ in range(repeat):
        h.md.Deserialize(h.sys, settled)
        h.t = t_settle
        t0 = time.perf_counter()
        t, xyz = h.forced(case.run_s, case.record_dt)
        wall = min(wall, time.perf_counter() - t0)
    h.close()
    out = metrics(t, xyz, nodes, drogue0, force0, case)
    out.update(elements=n, dt_s=dt, wall_s=wall, rtf=case.run_s / wall, settle_s=t_settle,
               hose_end_x_m=float(drogue0[0]), hose_end_z_m=float(drogue0[2]))
    return out


# ---- engagement case and the host step API (ours only) -------------------------------
def engagement_model(n: int = 40, duration: float = 30.0) -> Model:
    st = isa(15000 * FT)
    u = kcas_to_tas(254.0, 15000.0)
    hose = HoseProperties(length=75 * FT, outer_diameter=0.0635, inner_diameter=0.0445,
                          dry_mass_per_length=2.2, EI=50.0, EA=2.0e6, bending_damping=2.0,
                          axial_damping=300.0, total_length=80 * FT)
    drogue = DrogueProperties(mass=27.0, diameter=0.68, cd=0.82, cl=0.18, cp_aft_of_hinge=0.40)
    m0 = Model(hose, n, st.density, st.kinematic_viscosity, wind=uniform([u, 2.0, 0.0]), drogue=drogue)
    p0 = solve_static(m0).pos[-1]
    # probe contact at 2 s: 1.5 m forward and 0.3 m sideways in 1.5 s, hold, back out at
    # 20.2-21.7 s, disconnect at 22 s
    t = np.array([0.0, 2.0, 3.5, 20.2, 21.7, duration + 1.0])
    push = np.array([[0, 0, 0], [0, 0, 0], [-1.5, 0.3, 0], [-1.5, 0.3, 0], [0, 0, 0], [0, 0, 0]], float)
    end = EndConstraint(Trajectory(t, p0 + push), t_on=2.0, t_off=22.0)
    # the reel takes up what the probe pushes in, 0.3 s behind it, and pays it out again
    # 0.2 s ahead of the probe backing out
    L0 = hose.length
    reel = ReelProperties(mode="prescribed", payout_t=np.array([0.0, 2.3, 3.8, 20.0, 21.5, duration + 1.0]),
                          payout_length=np.array([L0, L0, L0 - 1.5, L0 - 1.5, L0, L0]))
    return Model(hose, n, st.density, st.kinematic_viscosity, wind=uniform([u, 2.0, 0.0]), drogue=drogue,
                 reel=reel, end=end)


def run_engagement(n: int = 40, duration: float = 30.0, repeat: int = 7) -> dict:
    m = engagement_model(n, duration)
    s0 = solve_static(m)
    simulate(m, 0.5, s0)
    wall = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = simulate(m, duration, s0)
        wall = min(wall, time.perf_counter() - t0)
    return {"elements": n, "simulated_s": duration, "dt_s": res.dt, "wall_s": wall, "rtf": duration / wall,
            "remeshed_to": int(np.min(res.n_hose_elements)),
            "probe_force_peak_N": float(np.max(np.linalg.norm(res.probe_force, axis=1)))}


def host_inputs(m: Model, t: float):
    """Tow point and probe states a host would send at time t (from the case's tables)."""
    tow = np.concatenate([m.tow.at(t), np.zeros(3)])
    probe = None
    if m.end is not None and m.end.t_on <= t <= m.end.t_off:
        p = m.end.path
        eps = 1e-4
        v = (p.at(t + eps) - p.at(t - eps)) / (2 * eps)
        probe = np.concatenate([p.at(t), v])
    return tow, probe


def run_stepper(rate_hz: float, n: int = 40, duration: float = 30.0, repeat: int = 7) -> dict:
    from solver.stepper import Stepper
    m = engagement_model(n, duration)
    s0 = solve_static(m)
    frame = 1.0 / rate_hz
    nf = int(round(duration * rate_hz))
    inputs = [host_inputs(m, (k + 1) * frame) for k in range(nf)]
    Stepper(m, s0).step(frame, *inputs[0])     # loads the compiled kernel
    wall = math.inf
    for _ in range(repeat):
        st = Stepper(m, s0)
        t0 = time.perf_counter()
        for k in range(nf):
            out = st.step(frame, *inputs[k])
        wall = min(wall, time.perf_counter() - t0)
    return {"rate_hz": rate_hz, "substeps": out.substeps, "wall_s": wall, "rtf": duration / wall,
            "frame_us": wall / nf * 1e6}


def stepper_memory(rate_hz: float = 60.0, minutes: float = 10.0, n: int = 40) -> dict:
    """Traced Python memory of the step API over a long run: after 1 minute and at the end."""
    from solver.stepper import Stepper
    m = engagement_model(n, 60.0 * minutes)
    st = Stepper(m)
    frame = 1.0 / rate_hz
    tow = np.zeros(6)
    nf = int(round(60.0 * minutes * rate_hz))
    tracemalloc.start()
    after_1min = None
    t0 = time.perf_counter()
    for k in range(nf):
        t = (k + 1) * frame
        tow[2] = 0.3 * math.sin(0.5 * t)
        tow[5] = 0.15 * math.cos(0.5 * t)
        st.step(frame, tow, None)
        if k + 1 == int(round(60.0 * rate_hz)):
            after_1min = tracemalloc.get_traced_memory()[0]
    wall = time.perf_counter() - t0
    end, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return {"rate_hz": rate_hz, "simulated_s": 60.0 * minutes, "wall_s": wall,
            "traced_after_1min_kB": after_1min / 1024, "traced_end_kB": end / 1024, "traced_peak_kB": peak / 1024}


# ---- report ---------------------------------------------------------------------------
def machine() -> str:
    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu} ({platform.machine()}), {os.cpu_count()} cores, Python {platform.python_version()}"


COMPARED = ("drogue_x_m", "drogue_z_m", "angle_tow_end_deg", "angle_drogue_end_deg", "tow_force_N",
            "frequency_hz", "damping_ratio")


def max_change(runs: list[dict]) -> dict:
    base = runs[0]
    return {k: max(abs(r[k] - base[k]) for r in runs[1:]) for k in COMPARED}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--elements", type=int, default=20, help="elements for the comparison (both codes)")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.add_argument("--skip-engagement", action="store_true", help="only the cross-code check")
    a = ap.parse_args()
    n = a.elements

    ours = run_ours(n)
    ours_conv = [ours, run_ours(n, dt=ours["dt_s"] / 2, repeat=1), run_ours(2 * n, repeat=1)]

    md_limit = moordyn_stable_dt(n, lo=2e-3 / n, hi=4e-2 / n)
    md_dt = 0.8 * md_limit
    theirs = run_moordyn(n, md_dt)
    # twice the elements: half the step (its limit scales with the element length)
    theirs_conv = [theirs, run_moordyn(n, md_dt / 2, repeat=1), run_moordyn(2 * n, md_dt / 2, repeat=1)]

    L = CASE.length
    agree = {
        "drogue_position_diff_m": float(math.hypot(ours["drogue_x_m"] - theirs["drogue_x_m"],
                                                   ours["drogue_z_m"] - theirs["drogue_z_m"])),
        "frequency_diff_pct": 100 * abs(ours["frequency_hz"] - theirs["frequency_hz"]) / theirs["frequency_hz"],
    }
    agree["drogue_position_diff_pct_of_length"] = 100 * agree["drogue_position_diff_m"] / L
    result = {
        "machine": machine(),
        "case": {"hose_length_m": L, "elements": n, "simulated_s": CASE.run_s},
        "ours": ours,
        "moordyn": dict(theirs, scheme="RK2", stability_limit_dt_s=md_limit),
        "speed_ratio": ours["rtf"] / theirs["rtf"],
        "agreement": agree,
        "convergence": {
            "ours": {"halved_step": max_change(ours_conv[:2]), "doubled_elements": max_change(ours_conv[::2]),
                     "dt_s": [r["dt_s"] for r in ours_conv]},
            "moordyn": {"halved_step": max_change(theirs_conv[:2]),
                        "doubled_elements": max_change(theirs_conv[::2]),
                        "dt_s": [r["dt_s"] for r in theirs_conv]},
        },
    }
    if not a.skip_engagement:
        result["engagement"] = {
            "simulate": run_engagement(),
            "step_api_60hz": run_stepper(60.0),
            "step_api_120hz": run_stepper(120.0),
            "step_api_memory": stepper_memory(),
        }
    if a.json:
        print(json.dumps(result))
        return
    report(result)


def report(r: dict) -> None:
    o, m = r["ours"], r["moordyn"]
    print(f"Peer check: towed hose and drogue, {r['case']['elements']} elements, {r['machine']}")
    rows = [
        ("drogue static x (m, aft of the tow point)", "drogue_x_m", "{:.4f}"),
        ("drogue static z (m, up from the tow point)", "drogue_z_m", "{:.4f}"),
        ("hose end (hinge) x (m)", "hose_end_x_m", "{:.4f}"),
        ("hose end (hinge) z (m)", "hose_end_z_m", "{:.4f}"),
        ("hose angle at tow end (deg below horiz.)", "angle_tow_end_deg", "{:.3f}"),
        ("hose angle at drogue end (deg below horiz.)", "angle_drogue_end_deg", "{:.3f}"),
        ("tow force (N)", "tow_force_N", "{:.1f}"),
        ("tow force x, z (N)", None, None),
        ("free response frequency (Hz)", "frequency_hz", "{:.4f}"),
        ("free response damping ratio", "damping_ratio", "{:.4f}"),
        ("free response fit residual (RMS / RMS)", "fit_residual", "{:.3f}"),
        ("integration step (s)", "dt_s", "{:.3g}"),
        ("wall time, 16 s run (s)", "wall_s", "{:.3f}"),
        ("real-time factor", "rtf", "{:.1f}"),
    ]
    print(f"  {'':44s} {'ours':>15s} {'MoorDyn':>15s}")
    for label, key, fmt in rows:
        if key is None:
            a, b = (f"{x['tow_force_x_N']:.1f}, {x['tow_force_z_N']:.1f}" for x in (o, m))
        else:
            a, b = fmt.format(o[key]), fmt.format(m[key])
        print(f"  {label:44s} {a:>15s} {b:>15s}")
    ag = r["agreement"]
    print(f"  drogue positions differ by {ag['drogue_position_diff_m'] * 1000:.1f} mm "
          f"({ag['drogue_position_diff_pct_of_length']:.3f} % of the hose length; limit 1 %), "
          f"frequencies by {ag['frequency_diff_pct']:.2f} % (limit 2 %)")
    print(f"  speed ratio (ours / MoorDyn real-time factor): {r['speed_ratio']:.1f}")
    print(f"  MoorDyn: RK2; the largest step at which its trail settles is {m['stability_limit_dt_s']:.3g} s "
          f"(used 80 %); it settled dynamically in {m['settle_s']:.0f} s simulated")
    print("  convergence (largest change of each figure):")
    for code in ("ours", "moordyn"):
        c = r["convergence"][code]
        for what in ("halved_step", "doubled_elements"):
            d = c[what]
            print(f"    {code:8s} {what.replace('_', ' '):17s} x {d['drogue_x_m'] * 1e3:.2f} mm, "
                  f"z {d['drogue_z_m'] * 1e3:.2f} mm, angles {d['angle_tow_end_deg']:.3f}/"
                  f"{d['angle_drogue_end_deg']:.3f} deg, tow force {d['tow_force_N']:.2f} N, "
                  f"frequency {d['frequency_hz'] * 1e3:.2f} mHz, damping {d['damping_ratio']:.4f}")
    if "engagement" in r:
        e = r["engagement"]
        s = e["simulate"]
        print(f"40-element 3D engagement (probe contact, reel take-up to {s['remeshed_to']} elements), "
              f"{s['simulated_s']:g} s:")
        print(f"  simulate: step {s['dt_s'] * 1e3:.3f} ms, wall {s['wall_s']:.3f} s, {s['rtf']:.0f}x real time")
        for k in ("step_api_60hz", "step_api_120hz"):
            x = e[k]
            print(f"  step API at {x['rate_hz']:.0f} Hz: {x['substeps']} sub-steps a frame, "
                  f"{x['frame_us']:.0f} us a frame, {x['rtf']:.0f}x real time")
        mm = e["step_api_memory"]
        print(f"  step API memory over {mm['simulated_s'] / 60:.0f} min at {mm['rate_hz']:.0f} Hz: traced "
              f"{mm['traced_after_1min_kB']:.1f} kB after 1 min, {mm['traced_end_kB']:.1f} kB at the end "
              f"(peak {mm['traced_peak_kB']:.1f} kB)")


if __name__ == "__main__":
    main()
