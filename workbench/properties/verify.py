"""Verification of the property tables (paper Fig. 9) and of how they interpolate.

The N=8 bench model with constants looked up in the finished table is released
from a pushed-down tip (or its end weight struck) and integrated in time
(`solver.integrate.simulate`); the simulated tip acceleration is written as a
ring-down record and measured by `measure.measure_ringdown`, unchanged.
"""
from __future__ import annotations

import math
from typing import Iterable

import numpy as np
import pandas as pd

from flighttest import FlightRecord, make_record
from solver.integrate import simulate
from solver.linear import linearize
from solver.properties import PropertyTable
from solver.state import State
from workbench.hardware import HoseSheet
from workbench.properties.measure import measure_ringdown
from workbench.properties.rig import BenchRig, equilibrium, rig_mode

VERIFY_ELEMENTS = 8
# Fig. 9 acceptance: simulated against measured, relative
FREQUENCY_TOLERANCE = 0.005
DAMPING_TOLERANCE = 0.02
RECORD_DT = 1e-3   # s, the bench accelerometers' 1 kHz
HOLD_S = 1.0       # s of the simulated rig held still before its release


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

