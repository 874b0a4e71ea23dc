"""What the best explanation leaves: the residual once a family's best
explanation is in, channel by channel, split into what is steady in each log
and what varies, each against the log's noise floor.

A steady part of one sign and like size in every log of a family, well above
the noise, is a model-form difference (the same in every flight of the
hardware), not an event of one flight: it is reported as such, with where it
lies and its size against the noise, beside the explanation. The
hose channel is split by station as well, since a shape difference lies
somewhere along the hose, not everywhere.
"""
from __future__ import annotations

import math

import numpy as np

from flighttest.residual import STATION_M, Residual
from workbench.diagnosis.evaluate import gap
from workbench.diagnosis.setup import NOISE_FACTOR

# steady parts within this factor of each other (largest over smallest) are "like size"
LIKE_SIZE = 3.0


def _steady_split(r: np.ndarray, floor: np.ndarray) -> dict:
    """A set of components' mean (the steady part), RMS about it (the varying
    part) and RMS floor, m; `real` when the mean or the varying part passes
    NOISE_FACTOR x the floor (a mean of n components is n-fold averaged: its
    floor is the RMS floor over sqrt(n))."""
    mean = float(np.mean(r))
    varying = gap(r - mean)
    fl = gap(floor)
    fl_mean = fl / math.sqrt(len(r))
    return {"steady_m": mean, "varying_m": varying, "floor_m": fl,
            "steady_real": bool(abs(mean) > NOISE_FACTOR * fl_mean),
            "varying_real": bool(varying > NOISE_FACTOR * fl)}


def _common(per_log: dict) -> bool:
    """One sign and like size in every log, each beyond NOISE_FACTOR x the
    components' own noise floor (not only its mean's): the same in every flight,
    and as large as a single component could show it."""
    if len(per_log) < 2:
        return False
    s = np.array([v["steady_m"] for v in per_log.values()])
    real = all(abs(v["steady_m"]) > NOISE_FACTOR * v["floor_m"] for v in per_log.values())
    same_sign = bool(np.all(s > 0) or np.all(s < 0))
    return real and same_sign and float(np.max(np.abs(s)) / np.min(np.abs(s))) <= LIKE_SIZE


def remainder(residuals: dict[str, Residual]) -> dict:
    """{channel: {"per_log": {log: split}, "common": bool, "steady_m": the
    logs' mean steady part, "floor_m"}} and, for the hose, the same per
    `STATION_M` station band under "hose stations" (keyed 'from-to m')."""
    out: dict = {}
    channels = sorted({str(c) for R in residuals.values() for c in np.unique(R.channel)})
    for ch in channels:
        per_log = {}
        for log, R in residuals.items():
            s = R.channel == ch
            if s.any():
                per_log[log] = _steady_split(R.r[s], R.floor[s])
        if per_log:
            out[ch] = _entry(per_log)
    stations: dict = {}
    for log, R in residuals.items():
        s = (R.channel == "hose") & np.isfinite(R.station)
        if not s.any():
            continue
        band = np.floor(R.station[s] / STATION_M).astype(int)
        for b in np.unique(band):
            k = band == b
            stations.setdefault(int(b), {})[log] = _steady_split(R.r[s][k], R.floor[s][k])
    if stations:
        out["hose stations"] = {f"{b * STATION_M:g} to {(b + 1) * STATION_M:g} m": _entry(v)
                                for b, v in sorted(stations.items())}
    return out


def _entry(per_log: dict) -> dict:
    return {"per_log": per_log, "common": _common(per_log),
            "steady_m": float(np.mean([v["steady_m"] for v in per_log.values()])),
            "varying_m": gap([v["varying_m"] for v in per_log.values()]),
            "floor_m": gap([v["floor_m"] for v in per_log.values()])}


def sentences(rem: dict, explained_by: str) -> list[str]:
    """The remainder in words: each channel whose steady part is common to
    every log (model form), then the largest varying parts above the noise."""
    out = []
    entries = [(k, v) for k, v in rem.items() if k != "hose stations"]
    entries += [(f"hose at {k}", v) for k, v in rem.get("hose stations", {}).items()]
    for name, v in sorted(entries, key=lambda kv: -abs(kv[1]["steady_m"])):
        if v["common"]:
            ratio = abs(v["steady_m"]) / max(v["floor_m"], 1e-12)
            out.append(f"{name}: {v['steady_m']:+.3f} m steady in every log ({ratio:.0f} x its noise floor "
                       f"{v['floor_m']:.3f} m) with {explained_by} in: a model-form difference, the same in "
                       f"every flight, that the explanation leaves.")
    varying = sorted(((k, v) for k, v in entries if v["varying_m"] > NOISE_FACTOR * v["floor_m"]
                      and not k.startswith("hose at")), key=lambda kv: -kv[1]["varying_m"])
    for name, v in varying[:2]:
        out.append(f"{name}: {v['varying_m']:.3f} m varies within the logs beyond the noise "
                   f"({v['floor_m']:.3f} m) with {explained_by} in.")
    return out
