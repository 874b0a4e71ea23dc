"""One proving-ground log: a test card, its inputs, the truth model with
effects on, and the instruments' nuisance layer, written through flighttest's
writer in the shared logs' kinds, topics and rates.

Nuisance (every log): light Dryden turbulence of another scale length than
the library's default (unless turbulence is the withheld effect); a drogue
tracker at 30 Hz whose clock runs with an offset, a drift and jitter (the
samples describe other instants than their stamps say), noisier along the
line of sight (x) than across it, with dropouts and a burst out of view; hose
points digitised from video at 10 Hz at jittered stations; a noisy tow-point
track with a slow INS drift. The doublet is a filtered square stick input on
top of the tanker's own low-frequency heave, not the diagnosis's sine.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from flighttest import make_record, read_record, write_record
from solver.effects import EFFECTS
from solver.integrate import simulate
from solver.statics import solve_static
from workbench import log_inputs
from workbench.proving.physics import draw_form, probe_coupling, truth_case, truth_model

ROOT = Path(__file__).resolve().parent.parent.parent
FLIGHT = ROOT / "flighttest" / "logs" / "flight"
CARDS = {"pitch_doublet": ("PD-G3-1", "PD-G3-2", "PD-G3-3"),
         "trail": ("TR-KDC10-E7", "TR-KDC10-E8", "TR-KDC10-E9", "TR-KDC10-E11"),
         "engagement": ("EN-KDC10-E7", "EN-KDC10-E11")}

TRACKER_HZ = 30.0
TRACKER_NOISE_M = (0.025, 0.012, 0.012)   # x (line of sight), y, z
TRACKER_DROPOUT = 0.03
CLOCK_OFFSET_S = 0.01                      # +/- tracker clock against the tow-point clock
CLOCK_DRIFT = 2e-4                         # +/- s/s
CLOCK_JITTER_S = 0.002
VIDEO_HZ = 10.0
VIDEO_NOISE_M = 0.04
VIDEO_STATION_JITTER_M = 0.3
TOW_NOISE_M = 0.003
NUISANCE_SIGMA_MPS = (0.1, 0.3)            # light turbulence, below MIL-HDBK-1797's 'light'
NUISANCE_SCALE_M = (250.0, 900.0)


def _either(rng, *bands):
    """Uniform within one of `bands` (below or above the baseline), chosen at random."""
    return float(rng.uniform(*bands[int(rng.integers(len(bands)))]))


def _signed(rng, lo, hi):
    return float(rng.uniform(lo, hi) * rng.choice([-1.0, 1.0]))


# Each effect's draw: large enough to be seen through the nuisance, calibrated
# parameters inside the registry's search ranges (a test checks it), the
# others (shape) drawn too: the diagnosis holds them at their defaults.
DRAWS = {
    "drogue_lift": lambda r, T: {"scale": _either(r, (0.0, 0.5), (1.6, 2.4))},
    "drogue_drag": lambda r, T: {"scale": _either(r, (0.5, 0.72), (1.45, 2.1))},
    "hose_drag": lambda r, T: {"crossflow": _either(r, (0.35, 0.6), (1.8, 2.8)), "friction": float(r.uniform(0.7, 1.5))},
    "hose_stiffness": lambda r, T: {"bending": _either(r, (0.2, 0.4), (2.5, 5.0)), "axial": float(r.uniform(0.7, 1.4))},
    "steady_wind": lambda r, T: {"vertical_mps": _signed(r, 1.5, 4.0), "lateral_mps": _signed(r, 1.0, 3.0)},
    "tanker_wake": lambda r, T: {"strength": float(r.uniform(0.6, 1.5)), "core_radius_m": float(r.uniform(0.3, 2.5)),
                                 "vertical_offset_m": float(r.uniform(-1.5, 0.5)),
                                 "lateral_offset_m": float(r.uniform(-1.5, 1.5)),
                                 "fuselage_drag_area_m2": float(0.6 * r.uniform(0.5, 2.0))},
    "turbulence": lambda r, T: {"sigma_mps": float(r.uniform(0.8, 1.6)), "length_scale_m": float(r.uniform(300, 800)),
                                "seed": int(r.integers(1, 2 ** 30))},
    "gust": lambda r, T: {"vertical_mps": _signed(r, 1.5, 3.0), "length_m": float(r.uniform(50.0, 200.0)),
                          "start_s": float(r.uniform(0.3, 0.6) * T), "full_wave": 1},
    "reel_lag": lambda r, T: {"dead_time_s": float(r.uniform(0.15, 0.4)), "lag_s": float(r.uniform(0.03, 0.1)),
                              "hold_N_s_m": float(r.uniform(1000.0, 4000.0))},
    "sensor_lag": lambda r, T: {"delay_s": _signed(r, 0.12, 0.35)},
    "bow_wave": lambda r, T: {"strength": float(r.uniform(1.3, 2.6)), "body_radius_m": float(r.uniform(0.9, 1.4)),
                              "nose_x_m": float(r.uniform(0.6, 1.6)), "nose_y_m": float(r.uniform(-1.2, -0.6))},
}
# Every library effect that can act on a kind (gust and turbulence included:
# a real flight has them whether or not the diagnosis can name them).
KIND_EFFECTS = {
    "pitch_doublet": ["drogue_lift", "drogue_drag", "hose_drag", "hose_stiffness", "steady_wind", "tanker_wake",
                      "turbulence", "gust", "sensor_lag"],
    "trail": ["drogue_lift", "drogue_drag", "hose_drag", "steady_wind", "tanker_wake", "turbulence"],
    "engagement": ["drogue_lift", "drogue_drag", "hose_drag", "hose_stiffness", "steady_wind", "tanker_wake",
                   "turbulence", "bow_wave", "reel_lag", "sensor_lag"],
}
# every effect an event of a flight can carry (model-form ones are the form's: physics.py)
assert set(DRAWS) == {e for e in EFFECTS if not EFFECTS[e].model_form}

# The parameters that set each effect's size (its shape, time and seed left as
# drawn): what a subtle log shrinks towards the parameter's off value.
MAGNITUDE = {"drogue_lift": ("scale",), "drogue_drag": ("scale",), "hose_drag": ("crossflow",),
             "hose_stiffness": ("bending",), "steady_wind": ("vertical_mps", "lateral_mps"),
             "tanker_wake": ("strength",), "turbulence": ("sigma_mps",), "gust": ("vertical_mps",),
             "reel_lag": ("dead_time_s",), "sensor_lag": ("delay_s",), "bow_wave": ("strength",)}
assert set(MAGNITUDE) == set(DRAWS)
# A subtle log keeps this share of each drawn size (uniform), towards the
# records "near the sensor noise" the product is tried on (issue 13): the
# one-effect family's signatures are a median 11 times their log's noise
# floor (its campaign's rows, signature_gap_m / signature_floor_m), and a
# signature is about linear in a small effect's size. A factor with a
# data-sheet tolerance stays at least SUBTLE_MIN_TOLERANCES of it off the
# sheet: nearer, it is a calibration of the sheet's value, no event to name.
SUBTLE_SHARE = (0.15, 0.4)
SUBTLE_MIN_TOLERANCES = 1.5


def shrink(effect: str, params: dict, share: float) -> dict:
    """`params` of `effect` with its size (`MAGNITUDE`) brought to `share` of
    its departure from the parameter's off value, and no nearer the data
    sheet than `SUBTLE_MIN_TOLERANCES` x the parameter's tolerance."""
    out = dict(params)
    for name in MAGNITUDE[effect]:
        p = EFFECTS[effect].params[name]
        d = share * (params[name] - p.off)
        if p.tolerance is not None:
            d = np.sign(d) * max(abs(d), SUBTLE_MIN_TOLERANCES * p.tolerance * abs(p.off))
        out[name] = float(p.off + d)
    return out


# The flight condition moved about the card's: (key, how, size, format)
CONDITION_SPREAD = (("altitude_ft", "add", 2500.0, ".0f"), ("airspeed_kcas", "add", 15.0, ".1f"),
                    ("oat_F", "add", 5.0, ".1f"), ("tanker_gross_weight_lb", "times", 0.15, ".0f"))


def _card(kind: str, rng) -> tuple[dict, object]:
    """A real log of the kind (its test card: hardware ids, prescribed inputs)
    and its metadata with the flight condition moved at random."""
    like = read_record(FLIGHT / f"{CARDS[kind][int(rng.integers(len(CARDS[kind])))]}.mcap")
    raw = dict(like.info.raw, notes="generated by workbench.proving (independent-form proving ground)")
    for key, how, size, fmt in CONDITION_SPREAD:
        v = float(raw[key])
        v = v + rng.uniform(-size, size) if how == "add" else v * (1.0 + rng.uniform(-size, size))
        raw[key] = format(v, fmt)
    return raw, like


def _air(raw, T):
    t = np.arange(0.05, T, 0.1)
    kcas = float(raw["airspeed_kcas"])
    return pd.DataFrame({"altitude_ft": float(raw["altitude_ft"]), "kcas": kcas, "ktas": kcas * 1.2,
                         "oat_C": (float(raw["oat_F"]) - 32) * 5 / 9}, index=pd.Index(t, name="t_s"))


def _heave(rng, t, amp_m):
    """The tanker's own slow motion: a few random sinusoids of 0.05-0.3 Hz."""
    z = np.zeros_like(t)
    for _ in range(4):
        z += rng.uniform(0.3, 1.0) * np.sin(2 * np.pi * rng.uniform(0.05, 0.3) * t + rng.uniform(0, 2 * np.pi))
    return amp_m * z / 4.0


def _tow(t, z, rng, amp_xy):
    return pd.DataFrame({"x_m": _heave(rng, t, amp_xy), "y_m": _heave(rng, t, amp_xy), "z_m": z},
                        index=pd.Index(t, name="t_s"))


def _inputs(kind, raw, like, rng):
    """The prescribed channels (clean) of the generated test, and its length, s."""
    if kind == "pitch_doublet":
        T = 30.0
        t = np.arange(0.0, T, 0.01)
        amp, half, t0 = rng.uniform(0.5, 1.2), rng.uniform(0.7, 1.5), rng.uniform(5.0, 8.0)
        sq = np.where((t > t0) & (t < t0 + half), 1.0, 0.0) - np.where((t >= t0 + half) & (t < t0 + 2 * half), 1.0, 0.0)
        tau = rng.uniform(0.15, 0.35)   # the airframe's response lag to the stick
        z = np.zeros_like(t)
        for i in range(1, len(t)):
            z[i] = z[i - 1] + (amp * sq[i] - z[i - 1]) * (t[i] - t[i - 1]) / tau
        z += _heave(rng, t, 0.05)
        return {"/tanker/tow_point": _tow(t, z, rng, 0.02), "/air_data": _air(raw, T)}, T
    if kind == "trail":
        T = 20.0
        t = np.arange(0.0, T, 0.01)
        return {"/tanker/tow_point": _tow(t, _heave(rng, t, 0.03), rng, 0.01), "/air_data": _air(raw, T)}, T
    t_tow = like.topic("/tanker/tow_point").index
    # the card's tow point as the product reads it (filtered), sampled at its stamps
    tow = pd.DataFrame(log_inputs.tow_trajectory(like).at(t_tow.to_numpy(float)), columns=["x_m", "y_m", "z_m"],
                       index=t_tow)
    T = float(like.topic("/ors/drogue").index[-1])
    return {"/tanker/tow_point": tow, "/air_data": _air(raw, T),
            "/reel/hose_out": like.topic("/reel/hose_out"), "/probe/events": like.topic("/probe/events"),
            "/receiver/probe": like.topic("/receiver/probe").copy()}, T


def _tracker(rng, res, T, delay):
    """The drogue tracker: stamps at 30 Hz, each sample of the instant its
    drifting, jittering clock meant, `delay` s late, noisy, with dropouts."""
    t_st = np.arange(rng.uniform(0, 1 / TRACKER_HZ), T - 0.05, 1 / TRACKER_HZ)
    t_true = (t_st + rng.uniform(-CLOCK_OFFSET_S, CLOCK_OFFSET_S) + rng.uniform(-CLOCK_DRIFT, CLOCK_DRIFT) * t_st
              + rng.normal(0, CLOCK_JITTER_S, len(t_st)) - delay)
    tq = np.clip(t_true, res.t[0], res.t[-1])
    xyz = np.column_stack([np.interp(tq, res.t, res.end_xyz[:, c]) for c in range(3)])
    xyz += rng.normal(0, 1, xyz.shape) * np.array(TRACKER_NOISE_M)
    valid = rng.random(len(t_st)) > TRACKER_DROPOUT
    k = int(rng.integers(0, len(t_st) - 30))
    valid[k:k + int(rng.integers(5, 30))] = False
    xyz[~valid] = np.nan
    return pd.DataFrame({"x_m": xyz[:, 0], "y_m": xyz[:, 1], "z_m": xyz[:, 2], "valid": valid},
                        index=pd.Index(t_st, name="t_s"))


def _video(rng, res, T):
    """17 hose points a frame at 10 Hz, at stations jittered along the hose."""
    rows = []
    for tf in np.arange(rng.uniform(0, 1 / VIDEO_HZ), T - 0.1, 1 / VIDEO_HZ):
        j = int(np.argmin(np.abs(res.t - tf)))
        p = res.hose_points(j)
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
        sq = np.clip(np.linspace(0.0, s[-1], 17) + rng.normal(0, VIDEO_STATION_JITTER_M, 17), 0.0, s[-1])
        x = np.interp(sq, s, p[:, 0]) + rng.normal(0, VIDEO_NOISE_M, 17)
        z = np.interp(sq, s, p[:, 2]) + rng.normal(0, VIDEO_NOISE_M, 17)
        for i in np.flatnonzero(rng.random(17) > 0.05):
            rows.append((float(tf), int(i), float(x[i]), float(z[i])))
    return pd.DataFrame(rows, columns=["t_s", "point", "x_m", "z_m"])


def _truth_run(kind, raw, inp, like, form, phys, reel, T):
    """The truth model of this form with the physical effects `phys` (and the
    drum reel when `reel`), run through the test."""
    model = truth_model(truth_case(kind, raw, inp, form, phys, reel), inp, form)
    s0 = solve_static(model, float(model.tow.t[0]))
    if kind == "engagement":   # the probe holds the drogue from contact to disconnect
        model.end = log_inputs.drogue_while_engaged(like, s0.pos[-1], *probe_coupling(form, model))
    return simulate(model, T, s0, record_dt=0.01)


def generate(kind: str, effects: list[str], seed: int, out_dir: Path, reference: bool = False,
             subtle: bool = False) -> tuple[Path, dict] | tuple[Path, dict, object]:
    """One log with `effects` on at random parameters (`subtle`: their sizes
    shrunk to a `SUBTLE_SHARE` of the draw, `shrink`); its path and the truth
    (effects and parameters, the form differences, the nuisance). With
    `reference`, also the same flight without `effects` (a `SimulationResult`
    of the same form, inputs and nuisance turbulence, before the
    instruments): what the log would show without them, the yardstick of
    how visible they are (`campaign.signature`)."""
    rng = np.random.default_rng(seed)
    raw, like = _card(kind, rng)
    raw["test_id"] = f"PG-{kind}-{seed}"
    form = draw_form(rng, kind)
    topics, T = _inputs(kind, raw, like, rng)
    params = {e: DRAWS[e](rng, T) for e in effects}
    share = float(rng.uniform(*SUBTLE_SHARE)) if subtle else 1.0
    if subtle:
        params = {e: shrink(e, p, share) for e, p in params.items()}
    nuisance = {"sigma_mps": float(rng.uniform(*NUISANCE_SIGMA_MPS)),
                "length_scale_m": float(rng.uniform(*NUISANCE_SCALE_M)), "seed": int(rng.integers(1, 2 ** 30))}
    phys = {e: p for e, p in params.items() if not EFFECTS[e].comparison_only}
    phys.setdefault("turbulence", nuisance)
    reel = "drum" if "reel_lag" in effects else None
    inp = make_record(raw, topics, like.start_time_ns)
    if kind == "engagement":
        # the receiver flies to where this trail puts the drogue (no bow wave yet)
        pre_case = truth_case(kind, raw, inp, form, {k: v for k, v in phys.items() if k not in ("bow_wave", "reel_lag")})
        m0 = truth_model(pre_case, inp, form)
        d0 = solve_static(m0, float(m0.tow.t[0])).pos[-1]
        # ... and meets it there at contact: the probe track moved by the miss
        t_contact, _ = log_inputs.contact_window(like)
        probe = topics["/receiver/probe"]
        cols = ["x_m", "y_m", "z_m"]
        at_contact = np.array([np.interp(t_contact, probe.index, probe[c]) for c in cols])
        probe[cols] = probe[cols].to_numpy(float) + (d0 - at_contact)
        inp = make_record(raw, topics, like.start_time_ns)
    res = _truth_run(kind, raw, inp, like, form, phys, reel, T)
    out = dict(topics)
    tow = topics["/tanker/tow_point"]
    drift = np.outer(tow.index.to_numpy(float) / T, rng.normal(0, 0.01, 3))   # INS drift, ~1 cm over the test
    out["/tanker/tow_point"] = tow + rng.normal(0, TOW_NOISE_M, (len(tow), 3)) + drift
    delay = params.get("sensor_lag", {}).get("delay_s", 0.0)
    out["/ors/drogue"] = _tracker(rng, res, T, delay)
    if kind in ("trail", "engagement"):
        out["/video/hose"] = _video(rng, res, T)
    if reel:
        # the drum's own payout is what the pod's telemetry logs
        t_r = topics["/reel/hose_out"].index.to_numpy(float)
        out["/reel/hose_out"] = pd.DataFrame({"length_m": np.interp(t_r, res.t, res.reel_length)},
                                             index=pd.Index(t_r, name="t_s"))
    rec = make_record(raw, out, like.start_time_ns)
    path = Path(out_dir) / f"{raw['test_id']}.mcap"
    write_record(path, rec)
    truth = {"kind": kind, "effects": list(effects), "params": params, "seed": seed, "card": like.info.test_id,
             "form": form, "nuisance_turbulence": None if "turbulence" in params else nuisance, "share": share}
    if not reference:
        return path, truth
    without = {e: p for e, p in phys.items() if e not in effects}
    without.setdefault("turbulence", nuisance)
    # comparison-only effects (the tracker's lag) act on the instruments: the same run
    ref = res if without == phys and not reel else _truth_run(kind, raw, inp, like, form, without, None, T)
    return path, truth, ref
