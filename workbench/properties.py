"""Bench ring-down records -> per-element hose property tables (paper III.B, IV.A).

The pipeline, in the order `build_properties` runs it:

1. Measure every ring-down record with `flighttest` (`measure_ringdown`): the
   free decay after the release is the window `flighttest.analyze` finds (one
   period after the release until the envelope sinks into the noise); the
   first-mode frequency is the FFT peak of that window
   (`metrics.dominant_frequency`), the damping ratio its logarithmic decrement
   (`metrics.log_decrement` through `analyze_record`); the temperature is the
   mean of the two thermocouples, not the setpoint. Axial records are first
   split into axial and rocking motion (`metrics.axial_rocking`). The
   repetitions at one setpoint are averaged, with their spread.
2. Tune, for each element count N, the constants of an N-element model of the
   bench rig so that its first mode has the measured damped frequency and
   damping ratio. The bending rig is a horizontal cantilever clamped at the
   root, sagging under gravity in still air at the measured temperature; the
   axial rig hangs from a clamp with the end weight on its lower end. The
   mode comes from the linearised model (`linear_modes`): stiffness and
   damping matrices by central differences of the solver's own force kernel
   about the static (sagged or stretched) equilibrium, and the quadratic
   eigenproblem. A Broyden iteration in log(k), log(c) drives the mode onto
   the measurement.
3. The axial rig was tested at room temperature only: the axial constants at
   the bending temperatures follow the paper's assumption that they change in
   the same ratio as the bending ones do relative to room temperature. Room
   temperature lies above the bending tests, so the bending constants there
   are the temperature spline extrapolated (recorded as such).
4. Hoses never bench tested are derived from a tested one by the ratio of the
   cross-section second moments of area of the data-sheet diameters.
5. Verification (paper Fig. 9): the N=8 bench model with constants looked up
   in the finished table is released from a pushed-down tip and integrated in
   time (`solver.integrate.simulate`); the simulated tip acceleration is
   written as a ring-down record and measured by step 1, unchanged.

The result is one JSON document (`cases/properties/hose_properties.json`)
holding the tables and the provenance of every number: files and their
SHA-256, per-record measurements, group statistics, tuning residuals, the
assumptions and the verification.
"""
from __future__ import annotations

import hashlib
import json
import math
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterable

import numpy as np
import pandas as pd

from flighttest import metrics as M
from flighttest.analyze import analyze_record
from flighttest import FlightRecord, LogError, make_record, read_record
from solver import kernel as K
from solver.atmosphere import isa
from solver.hose import HoseProperties
from solver.integrate import simulate
from solver.model import Clamp, Model
from solver.properties import PropertyLibrary, PropertyTable
from solver.state import State
from solver.statics import solve_static
from workbench.errors import InputError
from workbench.hardware import Hardware, HoseSheet, load_hardware

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_PATH = ROOT / "cases" / "properties" / "hose_properties.json"
DEFAULT_LOGS = ROOT / "flighttest" / "logs" / "ringdown"
FORMAT = "hose-properties/1"
ELEMENT_COUNTS = (4, 6, 8, 12, 16, 24, 32, 48, 64)
VERIFY_ELEMENTS = 8
# Fig. 9 acceptance: simulated against measured, relative
FREQUENCY_TOLERANCE = 0.005
DAMPING_TOLERANCE = 0.02
# Hoses derived from a tested one: (derived, source). The paper's KDC-10 pod hose
# (section V.B): "similar construction to the KC-130 hose".
DERIVED_HOSES = (("kdc10_pod", "kc130_long"),)
# The tuned linear mode must hit the measurement to this (log) residual; far
# below the measurement's own scatter, and well above finite-difference noise.
TUNE_TOL = 1e-7
RECORD_DT = 1e-3   # s, the bench accelerometers' 1 kHz
# Equilibrium residual relative to the section's weight: tight enough that the
# mode computed about it is steady to ~1e-9 (tuning then does not chase noise),
# loose enough for the round-off of the stiffest (64-element) axial springs.
STATIC_TOL = 1e-8
HOLD_S = 1.0       # s of the simulated rig held still before its release


def fahrenheit_to_kelvin(t_F: float) -> float:
    return (t_F - 32.0) * 5.0 / 9.0 + 273.15


# =====================================================================================
# 1. Measurement
# =====================================================================================

def _accel_channel(record: FlightRecord) -> tuple[str, str, np.ndarray, np.ndarray]:
    """(topic, key prefix of analyze_record, t, acceleration) of a ring-down."""
    kind = record.info.test_kind
    if kind == "ringdown_bending":
        df = record.topic("/rig/accel/tip")
        return "/rig/accel/tip", "", df.index.to_numpy(float), df["a_mps2"].to_numpy(float)
    if kind == "ringdown_axial":
        df = record.topic("/rig/accel/weight")
        axial, _ = M.axial_rocking(df["a1_mps2"], df["a2_mps2"])
        return "/rig/accel/weight", "axial_", df.index.to_numpy(float), axial
    raise LogError(record.path, "metadata key 'test_kind'",
                   f"{kind!r} is not a ring-down (ringdown_bending or ringdown_axial)")


def measure_ringdown(record: FlightRecord) -> dict:
    """First-mode frequency (FFT) and damping ratio (log decrement) of one ring-down.

    The window and the log decrement are `analyze_record`'s; the frequency is
    the FFT peak (`metrics.dominant_frequency`) of the same window, resampled
    uniformly across any dropout. The least-squares fit of `analyze_record`
    is kept beside them as a cross-check. The displacement amplitude at the
    release is estimated from the acceleration at the start of the window,
    a / omega^2, grown back to the release with the measured decay rate; the
    verification releases its simulated rig from that amplitude."""
    res = analyze_record(record)
    _, pre, t, y = _accel_channel(record)
    ok = np.isfinite(t) & np.isfinite(y)
    t, y = t[ok], y[ok]
    fs = M.median_rate_hz(t)
    t0, t1 = res[f"{pre}decay_start_s"], res[f"{pre}decay_end_s"]
    tw, yw = M.resample_uniform(t, y, fs, t0, t1)
    fft = M.dominant_frequency(yw, fs, fmin=3.0 / (t[-1] - t[0]))
    f = fft.frequency_hz
    zeta = res[f"{pre}damping_ratio_logdec"]
    w = 2.0 * math.pi * f
    first = yw[: max(int(round(fs / f)), 2)]
    amp_start = 0.5 * float(np.max(first) - np.min(first)) / w ** 2
    decay = zeta * w / math.sqrt(1.0 - zeta ** 2)
    amp_release = amp_start * math.exp(decay * (t0 - res[f"{pre}release_s"]))
    info = record.info
    temp = res.get("temperature_F")
    out = {
        "test_id": info.test_id,
        "test_kind": info.test_kind,
        "hose": info.hose,
        "repetition": info.repetition,
        "setpoint_F": info.temperature_setpoint_F,
        "temperature_F": temp if temp is not None else info.temperature_setpoint_F,
        "temperature_source": "thermocouples (mean of t1, t2)" if temp is not None
        else "setpoint (record has no thermocouples)",
        "temperature_spread_F": res.get("temperature_spread_F"),
        "frequency_hz": f,
        "frequency_uncertainty_hz": fft.uncertainty_hz,
        "damping_ratio": zeta,
        "damping_ratio_half_cycle_spread": res[f"{pre}damping_spread"],
        "half_cycles": res[f"{pre}half_cycles"],
        "frequency_fit_hz": res[f"{pre}frequency_hz"],
        "damping_ratio_fit": res[f"{pre}damping_ratio"],
        "release_s": res[f"{pre}release_s"],
        "decay_window_s": [t0, t1],
        "amplitude_at_release_m": amp_release,
        "section_length_m": info.section_length_m,
        "tip_mass_kg": info.tip_mass_kg,
        "accel_lever_m": info.accel_lever_m,
    }
    if info.test_kind == "ringdown_axial":
        out["rocking_rms_mps2"] = res.get("rocking_rms_mps2")
        out["axial_rms_mps2"] = res.get("axial_rms_mps2")
    return out


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def measure_records(paths: Iterable[Path], progress: Callable[[str], None] | None = None) -> list[dict]:
    """`measure_ringdown` of every ring-down record in `paths`, with file and SHA-256.
    Records of other kinds are skipped; a record that cannot be measured is an error."""
    out = []
    for p in sorted(Path(x) for x in paths):
        rec = read_record(p)
        if rec.info.test_kind not in ("ringdown_bending", "ringdown_axial"):
            continue
        m = measure_ringdown(rec)
        m["file"] = p.name
        m["sha256"] = _sha256(p)
        out.append(m)
        if progress:
            progress(f"measured {p.name}: {m['frequency_hz']:.4f} Hz, zeta {m['damping_ratio']:.5f}, "
                     f"{m['temperature_F']:.2f} F")
    return out


def group_measurements(meas: list[dict]) -> list[dict]:
    """Repetitions averaged per (hose, kind, setpoint), as the paper did.

    A record without a setpoint forms its own group. Each group carries the
    mean measured temperature (the coordinate of the table), the mean,
    sample standard deviation, min and max of frequency and damping ratio, and
    the records it came from."""
    groups: dict[tuple, list[dict]] = {}
    for m in meas:
        key = (m["hose"], m["test_kind"],
               m["setpoint_F"] if m["setpoint_F"] is not None else f"rec:{m['test_id']}")
        groups.setdefault(key, []).append(m)
    out = []
    for (hose, kind, _), ms in groups.items():
        def stats(k):
            v = np.array([x[k] for x in ms], dtype=float)
            return {"mean": float(v.mean()), "std": float(v.std(ddof=1)) if len(v) > 1 else None,
                    "min": float(v.min()), "max": float(v.max())}
        lengths = {x["section_length_m"] for x in ms}
        tips = {x["tip_mass_kg"] for x in ms}
        if len(lengths) > 1 or len(tips) > 1:
            raise InputError(f"records {', '.join(x['file'] for x in ms)} of {hose} at one setpoint "
                             f"disagree on section_length_m {sorted(map(str, lengths))} or "
                             f"tip_mass_kg {sorted(map(str, tips))}")
        out.append({
            "hose": hose, "test_kind": kind, "setpoint_F": ms[0]["setpoint_F"], "n": len(ms),
            "temperature_F": stats("temperature_F"),
            "frequency_hz": stats("frequency_hz"),
            "damping_ratio": stats("damping_ratio"),
            "amplitude_at_release_m": float(np.mean([x["amplitude_at_release_m"] for x in ms])),
            "section_length_m": ms[0]["section_length_m"],
            "tip_mass_kg": ms[0]["tip_mass_kg"],
            "records": [x["file"] for x in ms],
        })
    out.sort(key=lambda g: (g["hose"], g["test_kind"], g["temperature_F"]["mean"]))
    return out


# =====================================================================================
# 2. Bench-rig models and their linear modes
# =====================================================================================

@dataclass(frozen=True)
class BenchRig:
    """A bench-test section as modelled: the hose from its data sheet, empty of
    fuel, `length` m long; `hanging` for the axial rig (clamped above, the end
    weight `tip_mass` kg below), else a horizontal cantilever (the tip
    accelerometer's mass is not on record and is left out)."""

    hose: str
    length: float
    outer_diameter: float
    inner_diameter: float
    dry_mass_per_length: float
    hanging: bool = False
    tip_mass: float = 0.0

    @classmethod
    def from_sheet(cls, sheet: HoseSheet, length: float | None, hanging: bool = False,
                   tip_mass: float | None = None) -> "BenchRig":
        L = length if length is not None else sheet.bench_section_length
        if L is None:
            raise InputError(f"hose {sheet.id}: no section_length_m in the records and no "
                             f"bench_section_length_m on the data sheet")
        return cls(sheet.id, float(L), sheet.outer_diameter, sheet.inner_diameter,
                   sheet.dry_mass_per_length, hanging, float(tip_mass or 0.0))

    @property
    def clamp_direction(self) -> tuple:
        return (0.0, 0.0, -1.0) if self.hanging else (1.0, 0.0, 0.0)

    def model(self, n_elements: int, constants, temperature_F: float) -> Model:
        """`constants` is a 4-tuple for every element, or an `element_constants` callable."""
        l = self.length / n_elements
        fn = constants if callable(constants) else (lambda _l, c=tuple(constants): c)
        ka, ca, kb, cb = fn(l)
        hose = HoseProperties(length=self.length, outer_diameter=self.outer_diameter,
                              inner_diameter=self.inner_diameter,
                              dry_mass_per_length=self.dry_mass_per_length,
                              EI=kb * l, EA=ka * l, bending_damping=cb * l, axial_damping=ca * l,
                              fuel_full=False, element_constants=fn)
        # still air in the rig at the measured temperature
        atm = isa(0.0, delta_temperature=fahrenheit_to_kelvin(temperature_F) - isa(0.0).temperature)
        return Model(hose, n_elements, atm.density, atm.kinematic_viscosity,
                     clamp=Clamp(self.clamp_direction), tip_mass=self.tip_mass)

    def straight(self, n_elements: int) -> np.ndarray:
        return np.outer(np.linspace(0.0, self.length, n_elements + 1), self.clamp_direction)


def equilibrium(model: Model, guess: np.ndarray) -> State:
    """Static equilibrium from `guess` (the solver's string guess hangs a
    cantilever straight down, far from its sagged shape)."""
    return solve_static(model, tol=STATIC_TOL, guess=guess)


@dataclass
class LinearModel:
    """M x'' + C x' + K x = 0 about an equilibrium, over the free nodes' DOFs `dofs`
    (indices into the flattened (node-1, xyz) array)."""

    mass: np.ndarray
    K: np.ndarray
    C: np.ndarray
    dofs: np.ndarray
    n_nodes: int

    def modes(self) -> tuple[np.ndarray, np.ndarray]:
        """Eigenvalues and displacement shapes (columns, full DOF layout) of the
        first-order form [[0, I], [-M^-1 K, -M^-1 C]]."""
        m = len(self.mass)
        A = np.zeros((2 * m, 2 * m))
        A[:m, m:] = np.eye(m)
        A[m:, :m] = -self.K / self.mass[:, None]
        A[m:, m:] = -self.C / self.mass[:, None]
        lam, V = np.linalg.eig(A)
        shapes = np.zeros((3 * (self.n_nodes - 1), len(lam)), dtype=complex)
        shapes[self.dofs] = V[:m]
        return lam, shapes

    def first_mode(self, component: int = 2) -> tuple[float, float]:
        """(damped frequency Hz, damping ratio) of the lowest lightly damped mode
        whose free-end motion lies mostly along `component` (2: z).

        Lowest by natural frequency |lambda|, not by the imaginary part: the
        short elements' zig-zag modes are overdamped, and a close pair of their
        real eigenvalues can come out of the solver as a complex pair with a
        tiny imaginary part. A ring-down shows several cycles, so its mode has
        zeta well below 1/2."""
        lam, shapes = self.modes()
        zeta = -lam.real / np.maximum(np.abs(lam), 1e-300)
        osc = np.flatnonzero((lam.imag > 0) & (zeta < 0.5))
        tip = shapes[-3:, osc]
        share = np.abs(tip[component]) ** 2 / np.maximum(np.sum(np.abs(tip) ** 2, axis=0), 1e-300)
        cand = osc[share > 0.5]
        if len(cand) == 0:
            raise RuntimeError("no lightly damped mode moves the free end along the measured axis")
        k = cand[np.argmin(np.abs(lam[cand]))]
        return float(lam[k].imag / (2.0 * math.pi)), float(zeta[k])

    def static_deflection(self, node: int, force) -> np.ndarray:
        """Displacement (n_nodes, 3) of every node under a small `force` (N) on `node`."""
        f = np.zeros(3 * (self.n_nodes - 1))
        f[3 * (node - 1):3 * node] = force
        dx = np.zeros_like(f)
        dx[self.dofs] = np.linalg.solve(self.K, f[self.dofs])
        return np.vstack([np.zeros(3), dx.reshape(-1, 3)])


def linearize(model: Model, state: State) -> LinearModel:
    """Stiffness K = -dF/dx and damping C = -dF/dv of `solver.kernel.compute_forces`
    about `state` (at rest), by central differences, and the lumped masses.

    Aerodynamic drag goes as |v| v and has no linear part at rest: a linear mode
    carries no air damping (the time simulation of the verification does).
    When the rig lies in the x-z plane the out-of-plane DOFs decouple exactly
    and are dropped."""
    nh = model.n_elements
    rest = state.rest
    n, mass, rest_all, ka, ca, kb, cb = model.build_arrays(nh, rest)
    P = model.params(nh, rest)
    work = np.zeros((6, n, 3))
    F = np.zeros((n, 3))
    ten = np.zeros(n)
    wp = model.wind.params
    pos0 = np.ascontiguousarray(state.pos, dtype=float)
    zero = np.zeros_like(pos0)

    def force(p, v):
        K.compute_forces(state.t, P, n, nh, p, v, mass, rest_all, ka, ca, kb, cb, wp, F, ten, work)
        return F[1:].ravel().copy()

    m = 3 * (n - 1)
    Kx = np.zeros((m, m))
    Cv = np.zeros((m, m))
    hx = 1e-6 * model.element_length
    for j in range(m):
        i, c = divmod(j, 3)
        p = pos0.copy()
        p[i + 1, c] += hx
        fp = force(p, zero)
        p[i + 1, c] -= 2 * hx
        fm = force(p, zero)
        Kx[:, j] = -(fp - fm) / (2 * hx)
        v = zero.copy()
        v[i + 1, c] = hx
        fp = force(pos0, v)
        v[i + 1, c] = -hx
        fm = force(pos0, v)
        Cv[:, j] = -(fp - fm) / (2 * hx)
    mdiag = np.repeat(mass[1:], 3)
    ydof = np.arange(1, m, 3)
    other = np.setdiff1d(np.arange(m), ydof)
    scale = max(np.max(np.abs(Kx)), 1e-300)
    planar = (np.max(np.abs(pos0[:, 1])) == 0.0 and model.gravity[1] == 0.0
              and np.max(np.abs(Kx[np.ix_(other, ydof)])) < 1e-9 * scale
              and np.max(np.abs(Cv[np.ix_(other, ydof)])) < 1e-9 * max(np.max(np.abs(Cv)), 1e-300))
    dofs = other if planar else np.arange(m)
    return LinearModel(mdiag[dofs], Kx[np.ix_(dofs, dofs)], Cv[np.ix_(dofs, dofs)], dofs, n)


def rig_mode(rig: BenchRig, n_elements: int, constants, temperature_F: float,
             guess: np.ndarray | None = None) -> tuple[float, float, State, LinearModel]:
    """First mode of the rig along z (bending: transverse; hanging: axial)."""
    model = rig.model(n_elements, constants, temperature_F)
    st = equilibrium(model, rig.straight(n_elements) if guess is None else guess)
    lin = linearize(model, st)
    f, z = lin.first_mode(2)
    return f, z, st, lin


# =====================================================================================
# 3. Tuning
# =====================================================================================

def _tune(evaluate: Callable[[float, float], tuple[float, float]], k0: float, c0: float,
          f_target: float, zeta_target: float, what: str) -> tuple[float, float, int, list]:
    """(k, c) with evaluate(k, c) == (f_target, zeta_target).

    Broyden's method on r = (ln f - ln f_target, ln zeta - ln zeta_target)
    over (ln k, ln c), started from the single-oscillator Jacobian (f ~ k^1/2,
    zeta ~ c k^-1/2); steps are limited to a factor e."""
    x = np.log([k0, c0])

    def resid(x):
        f, z = evaluate(float(np.exp(x[0])), float(np.exp(x[1])))
        if not (f > 0 and z > 0):
            raise RuntimeError(f"{what}: model mode lost (f={f}, zeta={z})")
        return np.array([math.log(f / f_target), math.log(z / zeta_target)])

    J = np.array([[0.5, 0.0], [-0.5, 1.0]])
    r = resid(x)
    history = [float(np.max(np.abs(r)))]
    for it in range(61):
        if np.max(np.abs(r)) < TUNE_TOL:
            return float(np.exp(x[0])), float(np.exp(x[1])), it, history
        if it == 60:
            break
        dx = -np.linalg.solve(J, r)
        big = np.max(np.abs(dx))
        if big > 1.0:
            dx /= big
        r_new = resid(x + dx)
        # Near the answer the residual's change is mostly the equilibrium's and
        # the differences' round-off: a Broyden update from it would spoil J,
        # and the current J already converges there.
        if np.max(np.abs(dx)) > 1e-5:
            J = J + np.outer(r_new - r - J @ dx, dx) / float(dx @ dx)
        x, r = x + dx, r_new
        history.append(float(np.max(np.abs(r))))
    raise RuntimeError(f"{what}: tuning did not converge (residual {history[-1]:.3g})")


def euler_bernoulli_guess(rig: BenchRig, n_elements: int, f_hz: float, zeta: float) -> tuple[float, float]:
    """(k_b, c_b) of a uniform clamped-free beam with this first mode and
    stiffness-proportional damping: omega = 1.8751^2 sqrt(EI / (mu L^4))."""
    mu = rig.dry_mass_per_length
    w = 2.0 * math.pi * f_hz
    EI = mu * rig.length ** 4 * (w / 1.8751 ** 2) ** 2
    l = rig.length / n_elements
    return EI / l, 2.0 * zeta * EI / w / l


def axial_spring_guess(rig: BenchRig, n_elements: int, f_hz: float, zeta: float) -> tuple[float, float]:
    """(k_a, c_a) of a massive spring carrying the end weight (a third of the
    section's own mass added to it), stiffness-proportional damping."""
    w = 2.0 * math.pi * f_hz
    m = rig.tip_mass + rig.dry_mass_per_length * rig.length / 3.0
    EA = m * w * w * rig.length
    l = rig.length / n_elements
    return EA / l, 2.0 * zeta * EA / w / l


def tune_bending(rig: BenchRig, n_elements: int, f_hz: float, zeta: float, temperature_F: float,
                 axial: tuple[float, float], start: tuple[float, float] | None = None,
                 guess: np.ndarray | None = None) -> dict:
    """k_b, c_b for which the N-element cantilever's first bending mode has the
    measured damped frequency and damping ratio (k_a, c_a given). `start`:
    first (k_b, c_b), default the Euler-Bernoulli beam's; `guess`: node
    positions to start the equilibrium from."""
    state = {"pos": guess}

    def evaluate(kb, cb):
        f, z, st, _ = rig_mode(rig, n_elements, (axial[0], axial[1], kb, cb), temperature_F, state["pos"])
        state["pos"] = st.pos
        state["sag"] = float(st.pos[-1, 2])
        return f, z

    k0, c0 = start if start is not None else euler_bernoulli_guess(rig, n_elements, f_hz, zeta)
    kb, cb, iters, hist = _tune(evaluate, k0, c0, f_hz, zeta,
                                f"{rig.hose} bending, {n_elements} elements, {temperature_F:.1f} F")
    return {"k_b": kb, "c_b": cb, "iterations": iters, "residual": hist[-1],
            "tip_sag_m": state["sag"], "equilibrium": state["pos"]}


def tune_axial(rig: BenchRig, n_elements: int, f_hz: float, zeta: float, temperature_F: float,
               bending: tuple[float, float], start: tuple[float, float] | None = None,
               guess: np.ndarray | None = None) -> dict:
    """k_a, c_a for which the N-element hanging section with its end weight has the
    measured axial frequency and damping ratio (k_b, c_b given)."""
    state = {"pos": guess}

    def evaluate(ka, ca):
        f, z, st, _ = rig_mode(rig, n_elements, (ka, ca, bending[0], bending[1]), temperature_F,
                               state["pos"])
        state["pos"] = st.pos
        state["stretch"] = float(-st.pos[-1, 2] - rig.length)
        return f, z

    k0, c0 = start if start is not None else axial_spring_guess(rig, n_elements, f_hz, zeta)
    ka, ca, iters, hist = _tune(evaluate, k0, c0, f_hz, zeta,
                                f"{rig.hose} axial, {n_elements} elements, {temperature_F:.1f} F")
    return {"k_a": ka, "c_a": ca, "iterations": iters, "residual": hist[-1],
            "static_stretch_m": state["stretch"], "equilibrium": state["pos"]}


def resample_chain(pos: np.ndarray, n_elements: int) -> np.ndarray:
    """Nodes of an `n_elements` chain placed at equal arc length along the
    polyline `pos` (a shape found with another element count, as a first guess)."""
    seg = np.linalg.norm(np.diff(pos, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    s_new = np.linspace(0.0, s[-1], n_elements + 1)
    return np.column_stack([np.interp(s_new, s, pos[:, c]) for c in range(3)])


# =====================================================================================
# 4. Time-domain bench simulation (the verification of paper Fig. 9)
# =====================================================================================

def simulate_ringdown(rig: BenchRig, n_elements: int, constants, temperature_F: float,
                      amplitude_m: float, f_hint_hz: float, zeta_hint: float) -> FlightRecord:
    """A simulated ring-down of the rig, as a record of the log contract.

    Bending: the tip is pushed down `amplitude_m` from the sagged equilibrium
    (the linear static deflection under a tip load, the shape the rod
    imposes) and let go. Axial: the end weight is struck, leaving it moving up
    at `amplitude_m` times the mode's circular frequency. The tip (weight)
    acceleration is the central difference of the recorded velocity, sampled
    at the bench's 1 kHz, after HOLD_S of the rig held still; the run lasts
    until the mode has decayed to 1 % (from the hints), plus three periods."""
    model = rig.model(n_elements, constants, temperature_F)
    st = equilibrium(model, rig.straight(n_elements))
    lin = linearize(model, st)
    tip = n_elements
    pos = st.pos.copy()
    vel = np.zeros_like(pos)
    if rig.hanging:
        f, _ = lin.first_mode(2)
        vel[tip, 2] = amplitude_m * 2.0 * math.pi * f
    else:
        d = lin.static_deflection(tip, (0.0, 0.0, -1.0))
        pos += d * (amplitude_m / abs(d[tip, 2]))
    w = 2.0 * math.pi * f_hint_hz
    duration = math.log(100.0) / (zeta_hint * w) + 3.0 / f_hint_hz
    r = simulate(model, duration, State(0.0, pos, vel, st.rest.copy(), st.reel_length),
                 record_dt=RECORD_DT)
    # The rig is held still before the release, as on the bench; the quiet
    # lead-in keeps the analysis' filters' start-up away from the decay.
    t_run = r.t - r.t[0]
    a_run = np.gradient(r.hose_vel[:, tip, 2], t_run)
    n_hold = int(round(HOLD_S / RECORD_DT))
    t = np.concatenate([np.arange(n_hold) * RECORD_DT, HOLD_S + t_run])
    a = np.concatenate([np.zeros(n_hold), a_run])
    idx = pd.Index(t, name="t_s")
    kind = "ringdown_axial" if rig.hanging else "ringdown_bending"
    info = {"schema_version": "1", "test_id": f"SIM-{rig.hose}-{kind}-{temperature_F:.1f}F-N{n_elements}",
            "test_kind": kind, "hose": rig.hose, "temperature_F": f"{temperature_F:.3f}",
            "section_length_m": f"{rig.length:.6g}",
            "notes": f"simulated bench ring-down, {n_elements} elements (workbench.properties)"}
    if rig.hanging:
        info["tip_mass_kg"] = f"{rig.tip_mass:.6g}"
        topics = {"/rig/accel/weight": pd.DataFrame({"a1_mps2": a, "a2_mps2": a}, index=idx)}
    else:
        topics = {"/rig/accel/tip": pd.DataFrame({"a_mps2": a}, index=idx)}
    tt = np.arange(0.0, t[-1], 1.0)
    topics["/rig/temperature"] = pd.DataFrame({"t1_F": np.full(len(tt), temperature_F),
                                               "t2_F": np.full(len(tt), temperature_F)},
                                              index=pd.Index(tt, name="t_s"))
    return make_record(info, topics, start_time_ns=0)


# =====================================================================================
# 5. The whole build
# =====================================================================================

def second_moment_of_area(sheet: HoseSheet) -> float:
    """pi (D^4 - d^4) / 64 of the data sheet's outer and inner diameters, m^4."""
    return math.pi * (sheet.outer_diameter ** 4 - sheet.inner_diameter ** 4) / 64.0


def _code_version() -> dict:
    def git(*args):
        try:
            return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True,
                                  timeout=10, check=True).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            return None
    commit = git("rev-parse", "HEAD")
    dirty = git("status", "--porcelain", "--", "solver", "flighttest", "workbench")
    # the files whose code made the numbers, hashed: exact even when uncommitted
    files = ("workbench/properties.py", "solver/properties.py", "solver/kernel.py", "solver/model.py",
             "solver/statics.py", "solver/integrate.py", "flighttest/metrics/damping.py", "flighttest/metrics/spectral.py", "flighttest/metrics/sampling.py", "flighttest/analyze.py")
    return {"git_commit": commit, "uncommitted_changes_in_code": bool(dirty) if dirty is not None else None,
            "source_sha256": {f: _sha256(ROOT / f) for f in files if (ROOT / f).exists()}}


def _one(values, what: str):
    vals = {v for v in values}
    if len(vals) != 1:
        raise InputError(f"{what} differ between records: {sorted(map(str, vals))}")
    return vals.pop()


def _bending_pass(rig: BenchRig, groups: list[dict], counts: list[int],
                  axial_at: Callable[[int, int], tuple[float, float]],
                  previous: dict | None, progress) -> dict:
    """Tuned (k_b, c_b) for every (temperature index, N); warm-started from
    `previous` (an earlier pass) or, along N, from the next coarser model."""
    out = {}
    for i, g in enumerate(groups):
        T = g["temperature_F"]["mean"]
        f, z = g["frequency_hz"]["mean"], g["damping_ratio"]["mean"]
        last = None
        for N in counts:
            l = rig.length / N
            if previous is not None:
                p = previous[(i, N)]
                start, guess = (p["k_b"], p["c_b"]), p["equilibrium"]
            elif last is not None:
                lp = rig.length / last[0]
                start = (last[1]["k_b"] * lp / l, last[1]["c_b"] * lp / l)
                guess = resample_chain(last[1]["equilibrium"], N)
            else:
                start, guess = None, None
            res = tune_bending(rig, N, f, z, T, axial_at(i, N), start, guess)
            out[(i, N)] = res
            last = (N, res)
        if progress:
            progress(f"tuned {rig.hose} bending at {T:.1f} F for N = {counts[0]}..{counts[-1]}")
    return out


def _table(hose: str, temps: np.ndarray, lengths: np.ndarray, counts: list[int], bend: dict,
           ka: np.ndarray, ca: np.ndarray, note: str) -> PropertyTable:
    """Table on (temperature, ascending element length) from per-(i, N) results."""
    order = np.argsort(lengths)
    kb = np.array([[bend[(i, counts[j])]["k_b"] for j in order] for i in range(len(temps))])
    cb = np.array([[bend[(i, counts[j])]["c_b"] for j in order] for i in range(len(temps))])
    return PropertyTable(hose, temps, lengths[order], ka[:, order], ca[:, order], kb, cb, note=note)


def build_hose(hose: str, groups: list[dict], sheet: HoseSheet, counts: list[int],
               progress=None) -> tuple[PropertyTable, dict]:
    """Property table and provenance of one bench-tested hose."""
    bend_g = [g for g in groups if g["hose"] == hose and g["test_kind"] == "ringdown_bending"]
    ax_g = [g for g in groups if g["hose"] == hose and g["test_kind"] == "ringdown_axial"]
    if len(bend_g) < 2:
        raise InputError(f"hose {hose}: bending ring-downs at {len(bend_g)} temperature(s); "
                         f"a temperature table needs at least 2")
    if len(ax_g) != 1:
        raise InputError(f"hose {hose}: expected axial ring-downs at one (room) temperature, found "
                         f"{len(ax_g)} setpoint(s)")
    ax = ax_g[0]
    if ax["tip_mass_kg"] is None:
        raise InputError(f"hose {hose}: axial records {', '.join(ax['records'])} lack tip_mass_kg")
    temps = np.array([g["temperature_F"]["mean"] for g in bend_g])
    if np.any(np.diff(temps) <= 0):
        raise InputError(f"hose {hose}: two bending setpoints have the same measured temperature")
    rig_b = BenchRig.from_sheet(sheet, _one([g["section_length_m"] for g in bend_g],
                                            f"hose {hose}: bending section lengths"))
    rig_a = BenchRig.from_sheet(sheet, ax["section_length_m"], hanging=True, tip_mass=ax["tip_mass_kg"])
    counts = sorted(counts)
    lengths = np.array([rig_b.length / N for N in counts])
    T_room = ax["temperature_F"]["mean"]
    f_a, z_a = ax["frequency_hz"]["mean"], ax["damping_ratio"]["mean"]

    # pass 1: bending with the axial constants of a massive spring (the bending
    # mode hardly feels them: doubling k_a moves it by ~1e-6)
    provisional = {N: axial_spring_guess(rig_a, N, f_a, z_a) for N in counts}
    bend1 = _bending_pass(rig_b, bend_g, counts, lambda i, N: provisional[N], None, progress)
    fill = np.array([[provisional[N][0] for N in counts]] * len(temps))
    fill_c = np.array([[provisional[N][1] for N in counts]] * len(temps))
    t1 = _table(hose, temps, lengths, counts, bend1, fill, fill_c, "")
    lo, hi = t1.temperature_range_F
    room_extrapolated = not (lo <= T_room <= hi)

    # axial at room temperature, with the bending constants there
    axial_room = {}
    last = None
    for N in counts:
        l = rig_a.length / N
        _, _, kb, cb = t1.constants(T_room, l, allow_extrapolation=True)
        start = guess = None
        if last is not None:
            lp = rig_a.length / last[0]
            start = (last[1]["k_a"] * lp / l, last[1]["c_a"] * lp / l)
            guess = resample_chain(last[1]["equilibrium"], N)
        axial_room[N] = tune_axial(rig_a, N, f_a, z_a, T_room, (kb, cb), start, guess)
        last = (N, axial_room[N])
    if progress:
        progress(f"tuned {hose} axial at {T_room:.1f} F for N = {counts[0]}..{counts[-1]}")

    def axial_from(table: PropertyTable) -> tuple[np.ndarray, np.ndarray, dict]:
        """k_a, c_a (temperature x N) scaled from room temperature like k_b, c_b."""
        ka = np.zeros((len(temps), len(counts)))
        ca = np.zeros_like(ka)
        room = {}
        for j, N in enumerate(counts):
            l = rig_b.length / N
            _, _, kb_r, cb_r = table.constants(T_room, l, allow_extrapolation=True)
            room[N] = (kb_r, cb_r)
            # tuned on the axial section's elements (length l_a): carried to the
            # table's length l through constant x length, the same N's continuum value
            to_l = (rig_a.length / N) / l
            for i in range(len(temps)):
                _, _, kb, cb = table.constants(temps[i], l)
                ka[i, j] = axial_room[N]["k_a"] * to_l * kb / kb_r
                ca[i, j] = axial_room[N]["c_a"] * to_l * cb / cb_r
        return ka, ca, room

    # pass 2: bending again with the final axial constants at each temperature
    ka, ca, _ = axial_from(t1)
    bend2 = _bending_pass(rig_b, bend_g, counts, lambda i, N: (ka[i, counts.index(N)],
                                                              ca[i, counts.index(N)]), bend1, progress)
    t2 = _table(hose, temps, lengths, counts, bend2, ka, ca, "")
    ka, ca, room = axial_from(t2)
    note = (f"measured: bending ring-downs at {len(temps)} temperatures; axial at {T_room:.1f} F "
            f"scaled to other temperatures like bending (assumption, untested)")
    table = _table(hose, temps, lengths, counts, bend2, ka, ca, note)

    change = max(abs(bend2[k]["k_b"] / bend1[k]["k_b"] - 1) for k in bend1)
    prov = {
        "status": "measured",
        "bench_rig": {
            "bending": {"section_length_m": rig_b.length, "clamp": "root clamped, horizontal",
                        "mass_per_length_kg_per_m": rig_b.dry_mass_per_length,
                        "fuel": "empty", "tip_mass_kg": 0.0,
                        "tip_mass_note": "tip accelerometer mass not on record; left out"},
            "axial": {"section_length_m": rig_a.length, "clamp": "hung from a fixed clamp",
                      "tip_mass_kg": rig_a.tip_mass, "mass_per_length_kg_per_m": rig_a.dry_mass_per_length},
            "air": "still air at sea-level ISA pressure and the measured temperature",
        },
        "bending_groups": bend_g,
        "axial_group": ax,
        "room_temperature_F": T_room,
        "room_temperature_outside_bending_range": room_extrapolated,
        "room_bending_constants": [
            {"n_elements": N, "element_length_m": rig_b.length / N, "k_b_N_m_per_rad": room[N][0],
             "c_b_N_m_s_per_rad": room[N][1],
             "source": "bending spline extrapolated" if room_extrapolated else "bending spline"}
            for N in counts],
        "bending_tuning": [
            {"temperature_F": float(temps[i]), "n_elements": N, "element_length_m": rig_b.length / N,
             "k_b_N_m_per_rad": bend2[(i, N)]["k_b"], "c_b_N_m_s_per_rad": bend2[(i, N)]["c_b"],
             "EI_equivalent_N_m2": bend2[(i, N)]["k_b"] * rig_b.length / N,
             "eta_b_equivalent_N_m2_s": bend2[(i, N)]["c_b"] * rig_b.length / N,
             "tip_sag_m": bend2[(i, N)]["tip_sag_m"], "mode_residual": bend2[(i, N)]["residual"],
             "iterations": bend2[(i, N)]["iterations"]}
            for i in range(len(temps)) for N in counts],
        "bending_change_second_pass_max": change,
        "axial_tuning": [
            {"temperature_F": T_room, "n_elements": N, "element_length_m": rig_a.length / N,
             "k_a_N_per_m": axial_room[N]["k_a"], "c_a_N_s_per_m": axial_room[N]["c_a"],
             "EA_equivalent_N": axial_room[N]["k_a"] * rig_a.length / N,
             "eta_a_equivalent_N_s": axial_room[N]["c_a"] * rig_a.length / N,
             "static_stretch_m": axial_room[N]["static_stretch_m"],
             "mode_residual": axial_room[N]["residual"], "iterations": axial_room[N]["iterations"]}
            for N in counts],
        "assumptions": [
            "axial stiffness and damping at the bending temperatures = room-temperature axial value "
            "x (bending value at that temperature / bending value at room temperature), per element "
            "length (paper III.B); no test checked this",
            (f"room temperature {T_room:.1f} F lies outside the bending tests' "
             f"{lo:.1f}..{hi:.1f} F: the bending constants there come from the cubic spline "
             f"extrapolated") if room_extrapolated else
            f"room temperature {T_room:.1f} F lies inside the bending tests' range",
        ] + ([f"axial section ({rig_a.length} m) and bending section ({rig_b.length} m) differ: "
              f"axial constants tuned with N elements are tabulated at the bending section's "
              f"length over N through constant x length"]
             if abs(rig_a.length - rig_b.length) > 1e-9 else []),
    }
    return table, prov


def derive_hose(source: PropertyTable, source_sheet: HoseSheet, sheet: HoseSheet) -> tuple[PropertyTable, dict]:
    """A hose never bench tested, from one of like construction: every constant
    scaled by the ratio of cross-section second moments of area (paper V.B)."""
    ratio = second_moment_of_area(sheet) / second_moment_of_area(source_sheet)
    note = (f"derived (never bench tested): {source.hose} x {ratio:.4f}, the ratio of "
            f"cross-section second moments of area from the data-sheet diameters")
    table = source.scaled(sheet.id, ratio, note)
    area = ((sheet.outer_diameter ** 2 - sheet.inner_diameter ** 2)
            / (source_sheet.outer_diameter ** 2 - source_sheet.inner_diameter ** 2))
    return table, {
        "status": "derived",
        "derived_from": source.hose,
        "scale_factor": ratio,
        "basis": (f"I = pi (D^4 - d^4)/64: {sheet.id} D={sheet.outer_diameter} m d={sheet.inner_diameter} m, "
                  f"{source_sheet.id} D={source_sheet.outer_diameter} m d={source_sheet.inner_diameter} m"),
        "assumptions": [
            f"{sheet.id} is of construction like {source.hose} (paper V.B); no bench test",
            f"all four constants, axial included, scale with the second moment of area as in the paper; "
            f"the cross-section area ratio ({area:.4f}) would be the alternative for the axial ones",
        ],
    }


def verify_group(table: PropertyTable, rig: BenchRig, group: dict, n_elements: int,
                 allow_extrapolation: bool = False) -> dict:
    """One measured group (a setpoint's repetitions) against the N-element rig
    with the table's constants at the group's mean temperature, simulated in
    time and measured like the bench records (paper Fig. 9)."""
    T = group["temperature_F"]["mean"]
    f, z = group["frequency_hz"]["mean"], group["damping_ratio"]["mean"]
    consts = table.element_constants(T, allow_extrapolation=allow_extrapolation)
    f_lin, z_lin, _, _ = rig_mode(rig, n_elements, consts, T)
    sim = simulate_ringdown(rig, n_elements, consts, T, group["amplitude_at_release_m"], f, z)
    ms = measure_ringdown(sim)
    ef = ms["frequency_hz"] / f - 1.0
    ez = ms["damping_ratio"] / z - 1.0
    return {
        "hose": table.hose, "test": "axial" if rig.hanging else "bending",
        "temperature_F": T, "n_elements": n_elements,
        "element_length_m": rig.length / n_elements,
        "frequency_measured_hz": f, "frequency_measured_std_hz": group["frequency_hz"]["std"],
        "frequency_simulated_hz": ms["frequency_hz"], "frequency_error_pct": 100.0 * ef,
        "damping_measured": z, "damping_measured_std": group["damping_ratio"]["std"],
        "damping_simulated": ms["damping_ratio"], "damping_error_pct": 100.0 * ez,
        "frequency_linear_hz": f_lin, "damping_linear": z_lin,
        "within_tolerance": bool(abs(ef) <= FREQUENCY_TOLERANCE and abs(ez) <= DAMPING_TOLERANCE),
        "constants_extrapolated_in_temperature": bool(allow_extrapolation),
        "simulated_decay_window_s": ms["decay_window_s"],
        "simulated_half_cycles": ms["half_cycles"],
        "records": group["records"],
    }


def verify_hose(table: PropertyTable, prov: dict, sheet: HoseSheet, n_elements: int,
                progress=None) -> list[dict]:
    """Paper Fig. 9 at every tested temperature of the hose (see `verify_group`)."""
    rows = []
    rig_b = BenchRig.from_sheet(sheet, prov["bench_rig"]["bending"]["section_length_m"])
    jobs = [(rig_b, g, False) for g in prov["bending_groups"]]
    ax = prov["axial_group"]
    rig_a = BenchRig.from_sheet(sheet, ax["section_length_m"], hanging=True, tip_mass=ax["tip_mass_kg"])
    jobs.append((rig_a, ax, prov["room_temperature_outside_bending_range"]))
    for rig, g, extrap in jobs:
        rows.append(verify_group(table, rig, g, n_elements, extrap))
        if progress:
            r = rows[-1]
            progress(f"verified {table.hose} {r['test']} at {r['temperature_F']:.1f} F, N={n_elements}: "
                     f"frequency {r['frequency_error_pct']:+.3f} %, damping {r['damping_error_pct']:+.3f} %")
    return rows


def interpolation_checks(table: PropertyTable, prov: dict, sheet: HoseSheet,
                         off_grid_counts: Iterable[int] = (5, 10, 20, 40)) -> list[dict]:
    """How well the table carries between its grid points (linear modes, no
    time simulation): element counts between the tuned ones, at every tested
    temperature; and each interior tested temperature left out of the spline
    and predicted from the others (N=VERIFY_ELEMENTS). Errors are against the
    measured means, so the left-out ones include that group's scatter."""
    rig = BenchRig.from_sheet(sheet, prov["bench_rig"]["bending"]["section_length_m"])
    groups = prov["bending_groups"]
    rows = []
    for g in groups:
        T = g["temperature_F"]["mean"]
        f, z = g["frequency_hz"]["mean"], g["damping_ratio"]["mean"]
        for N in off_grid_counts:
            fm, zm, _, _ = rig_mode(rig, N, table.element_constants(T), T)
            rows.append({"hose": table.hose, "check": "element length between tuned ones",
                         "temperature_F": T, "n_elements": N, "element_length_m": rig.length / N,
                         "frequency_error_pct": 100 * (fm / f - 1), "damping_error_pct": 100 * (zm / z - 1)})
    temps = table.temperatures_F
    for i in range(1, len(temps) - 1):
        keep = np.arange(len(temps)) != i
        reduced = PropertyTable(table.hose, temps[keep], table.element_lengths,
                                *(getattr(table, n)[keep] for n in ("k_a", "c_a", "k_b", "c_b")))
        g = groups[i]
        T = g["temperature_F"]["mean"]
        N = VERIFY_ELEMENTS
        fm, zm, _, _ = rig_mode(rig, N, reduced.element_constants(T), T)
        rows.append({"hose": table.hose, "check": "temperature left out of the spline",
                     "temperature_F": T, "n_elements": N, "element_length_m": rig.length / N,
                     "frequency_error_pct": 100 * (fm / g["frequency_hz"]["mean"] - 1),
                     "damping_error_pct": 100 * (zm / g["damping_ratio"]["mean"] - 1)})
    return rows


METHOD = {
    "measurement": (
        "free decay = flighttest.analyze window (one period after the release, the largest "
        "excursion, until the band-passed envelope falls below 2 % or 3x the noise floor); "
        "frequency = FFT peak of that window (metrics.dominant_frequency: Hann, zero-padded, "
        "log-parabolic peak); damping ratio = logarithmic decrement (metrics.log_decrement via "
        "analyze_record 'damping_ratio_logdec'); axial records: (a1 + a2)/2 (metrics.axial_rocking); "
        "temperature = mean of both thermocouples over the record; repetitions at one setpoint "
        "averaged (sample std as spread)"),
    "tuning": (
        "per element count N: linear modes of the N-element bench model about its static "
        "equilibrium (stiffness and damping by central differences of solver.kernel.compute_forces, "
        "lumped masses, quadratic eigenproblem); lowest oscillatory mode with the free end moving "
        "mostly along z; Broyden iteration on (ln k, ln c) until damped frequency and damping ratio "
        f"match the measured means to {TUNE_TOL:g} (log residual)"),
    "interpolation": (
        "cubic spline (not-a-knot) in measured temperature per tabulated element length, then "
        "log-log linear in element length; beyond the tabulated lengths constant x length is held "
        "(continuum scaling); a temperature outside the tested range is refused unless "
        "allow_extrapolation"),
    "axial_temperature": (
        "paper III.B assumption: axial constants scale with temperature in the same ratio as the "
        "bending ones relative to room temperature (the axial test temperature); untested"),
    "derived_hoses": "scaled from a tested hose by the ratio of cross-section second moments of area",
    "interpolation_checks": (
        "linear modes of the bench model with table constants at element counts between the "
        "tuned ones, and at each interior tested temperature with that temperature left out of "
        "the spline; against the measured means"),
    "verification": (
        f"paper Fig. 9: N={VERIFY_ELEMENTS} bench model with table constants, static equilibrium, "
        "tip pushed down by the measured release amplitude (linear static shape under a tip load) "
        "or end weight struck, solver.integrate.simulate, tip acceleration written as a ring-down "
        "record and measured as above; tolerance "
        f"{100 * FREQUENCY_TOLERANCE:g} % frequency, {100 * DAMPING_TOLERANCE:g} % damping ratio"),
}


def build_properties(logs_dir: str | Path = DEFAULT_LOGS, hardware: Hardware | None = None,
                     element_counts: Iterable[int] = ELEMENT_COUNTS,
                     verify_elements: int = VERIFY_ELEMENTS,
                     derived: Iterable[tuple[str, str]] = DERIVED_HOSES,
                     progress: Callable[[str], None] | None = None) -> dict:
    """The property document (JSON-ready) from the ring-down records in `logs_dir`."""
    hw = hardware if hardware is not None else load_hardware()
    logs = Path(logs_dir)
    paths = sorted(logs.glob("*.mcap"))
    if not paths:
        raise InputError(f"{logs}: no .mcap records")
    counts = sorted({int(n) for n in element_counts})
    if not counts or counts[0] < 2:
        raise InputError(f"element counts must be integers >= 2, got {counts}")
    if verify_elements not in counts:
        raise InputError(f"the verification element count {verify_elements} is not among {counts}")
    meas = measure_records(paths, progress)
    if not meas:
        raise InputError(f"{logs}: no ring-down records")
    groups = group_measurements(meas)
    hoses = sorted({g["hose"] for g in groups if g["test_kind"] == "ringdown_bending"})
    tables: dict[str, PropertyTable] = {}
    provs: dict[str, dict] = {}
    verification: list[dict] = []
    checks: list[dict] = []
    for hose in hoses:
        sheet = hw.get("hose", hose)
        table, prov = build_hose(hose, groups, sheet, counts, progress)
        prov["records"] = sorted({r for g in prov["bending_groups"] + [prov["axial_group"]]
                                  for r in g["records"]})
        tables[hose], provs[hose] = table, prov
        verification += verify_hose(table, prov, sheet, verify_elements, progress)
        checks += interpolation_checks(table, prov, sheet)
    for name, source in derived:
        if name in tables or source not in tables or name not in hw.hoses:
            continue
        tables[name], provs[name] = derive_hose(tables[source], hw.get("hose", source), hw.get("hose", name))
    try:
        logs_label = str(logs.resolve().relative_to(ROOT))
    except ValueError:
        logs_label = str(logs)
    return {
        "format": FORMAT,
        "generated_by": "workbench properties build",
        "code_version": _code_version(),
        "inputs": {"logs": logs_label, "hardware": Path(hw.path).name,
                   "records": [{"file": m["file"], "sha256": m["sha256"]} for m in meas]},
        "element_counts": counts,
        "method": METHOD,
        "tables": {h: t.to_dict() for h, t in sorted(tables.items())},
        "hoses": provs,
        "measurements": meas,
        "verification": verification,
        "verification_tolerance_pct": {"frequency": 100 * FREQUENCY_TOLERANCE,
                                       "damping": 100 * DAMPING_TOLERANCE},
        "interpolation_checks": checks,
    }


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items() if k != "equilibrium"}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, float)):
        v = float(x)
        return v if math.isfinite(v) else None
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x


def write_properties(doc: dict, path: str | Path = DEFAULT_PATH) -> Path:
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    tmp = p.with_suffix(p.suffix + ".tmp")
    tmp.write_text(json.dumps(_jsonable(doc), indent=1, allow_nan=False) + "\n", encoding="utf-8")
    tmp.replace(p)
    return p


def read_properties(path: str | Path = DEFAULT_PATH) -> dict:
    p = Path(path)
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{p}: property file not found (make it with 'workbench properties build')") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{p}: not valid JSON ({exc})") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise InputError(f"{p}: format {doc.get('format') if isinstance(doc, dict) else None!r}, "
                         f"expected {FORMAT!r}")
    return doc


def load_library(path: str | Path = DEFAULT_PATH) -> PropertyLibrary:
    """The property tables of the data file, by hose id."""
    doc = read_properties(path)
    try:
        return PropertyLibrary.from_dict(doc["tables"])
    except (KeyError, ValueError, TypeError) as exc:
        raise InputError(f"{path}: bad property tables ({exc})") from None
