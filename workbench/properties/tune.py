"""Tuning: element constants for which the N-element bench rig rings like the tests.

For each element count N, a Broyden iteration in log(k), log(c) drives the
rig's first linear mode onto the measured damped frequency and damping ratio.
The axial rig was tested at room temperature only: the axial constants at the
bending temperatures follow the paper's assumption (III.B) that they change in
the same ratio as the bending ones relative to room temperature; room
temperature lies above the bending tests, so the bending constants there are
the temperature spline extrapolated (recorded as such). Hoses never bench
tested are derived from a tested one by the ratio of the cross-section second
moments of area of the data-sheet diameters (paper V.B).
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np

from solver.properties import PropertyTable
from workbench.errors import InputError
from workbench.hardware import HoseSheet
from workbench.properties.rig import BenchRig, rig_mode, second_moment_of_area

# The tuned linear mode must hit the measurement to this (log) residual; far
# below the measurement's own scatter, and well above finite-difference noise.
TUNE_TOL = 1e-7


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


def _tune_rig(rig: BenchRig, n_elements: int, f_hz: float, zeta: float, temperature_F: float,
              constants: Callable[[float, float], tuple], start: tuple[float, float], what: str,
              guess: np.ndarray | None) -> tuple[float, float, int, list, np.ndarray]:
    """The (k, c) pair that `constants(k, c)` places in the rig's (k_a, c_a,
    k_b, c_b), tuned so the rig's first mode has the measured frequency and
    damping ratio; each equilibrium starts from the last. Returns k, c, the
    iterations, the residual history and the final equilibrium."""
    state = {"pos": guess}

    def evaluate(k, c):
        f, z, st, _ = rig_mode(rig, n_elements, constants(k, c), temperature_F, state["pos"])
        state["pos"] = st.pos
        return f, z

    k, c, iters, hist = _tune(evaluate, start[0], start[1], f_hz, zeta,
                              f"{rig.hose} {what}, {n_elements} elements, {temperature_F:.1f} F")
    return k, c, iters, hist, state["pos"]


def tune_bending(rig: BenchRig, n_elements: int, f_hz: float, zeta: float, temperature_F: float,
                 axial: tuple[float, float], start: tuple[float, float] | None = None,
                 guess: np.ndarray | None = None) -> dict:
    """k_b, c_b for which the N-element cantilever's first bending mode has the
    measured damped frequency and damping ratio (k_a, c_a given). `start`:
    first (k_b, c_b), default the Euler-Bernoulli beam's; `guess`: node
    positions to start the equilibrium from."""
    start = start if start is not None else euler_bernoulli_guess(rig, n_elements, f_hz, zeta)
    kb, cb, iters, hist, pos = _tune_rig(rig, n_elements, f_hz, zeta, temperature_F,
                                         lambda k, c: (axial[0], axial[1], k, c), start, "bending", guess)
    return {"k_b": kb, "c_b": cb, "iterations": iters, "residual": hist[-1],
            "tip_sag_m": float(pos[-1, 2]), "equilibrium": pos}


def tune_axial(rig: BenchRig, n_elements: int, f_hz: float, zeta: float, temperature_F: float,
               bending: tuple[float, float], start: tuple[float, float] | None = None,
               guess: np.ndarray | None = None) -> dict:
    """k_a, c_a for which the N-element hanging section with its end weight has the
    measured axial frequency and damping ratio (k_b, c_b given)."""
    start = start if start is not None else axial_spring_guess(rig, n_elements, f_hz, zeta)
    ka, ca, iters, hist, pos = _tune_rig(rig, n_elements, f_hz, zeta, temperature_F,
                                         lambda k, c: (k, c, bending[0], bending[1]), start, "axial", guess)
    return {"k_a": ka, "c_a": ca, "iterations": iters, "residual": hist[-1],
            "static_stretch_m": float(-pos[-1, 2] - rig.length), "equilibrium": pos}


def resample_chain(pos: np.ndarray, n_elements: int) -> np.ndarray:
    """Nodes of an `n_elements` chain placed at equal arc length along the
    polyline `pos` (a shape found with another element count, as a first guess)."""
    seg = np.linalg.norm(np.diff(pos, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    s_new = np.linspace(0.0, s[-1], n_elements + 1)
    return np.column_stack([np.interp(s_new, s, pos[:, c]) for c in range(3)])


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

