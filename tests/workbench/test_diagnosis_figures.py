"""The where-map's channel x phase and station x band tables, its overlay
series, and the report drawing them (or, for an older diagnosis.json, saying
it cannot)."""
from __future__ import annotations

import copy
import dataclasses
import json
import re

import numpy as np
from numpy.testing import assert_allclose

from flighttest.residual import DROGUE, Observation, Residual
from workbench.diagnosis.report import diagnosis_html
from workbench.diagnosis.where import OVERLAY_POINTS, where_map
from workbench.provenance import ROOT

PHASES = (("steady trail", 0.0, 5.0), ("doublet", 5.0, 10.0), ("free response", 10.0, 20.0))
OFFSET_M = 0.3      # the one channel and phase the simulation misses by
FLOOR_M = 0.01


def _doublet(offset_m: float = OFFSET_M) -> tuple[Observation, Residual]:
    """A 30 Hz drogue log whose simulation misses drogue z by `offset_m` in
    the doublet only, as 0.25 s bin components with a 1 cm floor, and an
    engagement-like hose: 1 m off at stations 3-6 m in the doublet's window, 0 elsewhere."""
    t = np.arange(0.0, 20.0, 1 / 30)
    xyz = np.column_stack([np.full_like(t, -20.0), np.zeros_like(t), 0.5 * np.sin(2 * np.pi * 0.5 * t)])
    xyz += np.random.default_rng(1).normal(0.0, 0.005, xyz.shape)     # the tracker's noise: a floor for the bands
    d = np.zeros_like(xyz)
    d[(t >= 5.0) & (t < 10.0), 2] = offset_m
    ob = Observation("PD-TEST.mcap", "PD-TEST", "pitch_doublet", t, xyz, np.arange(0.0, 20.0 + 1e-9, 0.25), PHASES,
                     0.5)
    mid = np.arange(0.125, 20.0, 0.25)
    parts = {k: [] for k in ("r", "channel", "station", "t", "band")}
    for c, name in enumerate(DROGUE):
        parts["r"].append(np.where((mid >= 5.0) & (mid < 10.0) & (c == 2), offset_m, 0.0))
        parts["channel"] += [name] * len(mid)
        parts["station"].append(np.full(len(mid), np.nan))
        parts["t"].append(mid)
        parts["band"] += ["below 2 Hz"] * len(mid)
    st, tw = np.array([1.5, 4.5, 7.5] * 4), np.repeat([2.5, 7.5, 12.5, 17.5], 3)
    parts["r"].append(np.where((st == 4.5) & (tw == 7.5), 1.0, 0.0))
    parts["channel"] += ["hose"] * len(st)
    parts["station"].append(st)
    parts["t"].append(tw)
    parts["band"] += ["below 0.5 Hz"] * len(st)
    r, tt = np.concatenate(parts["r"]), np.concatenate(parts["t"])
    phase = np.array([next(p for p, a, b in PHASES if a <= x < b) for x in tt], dtype=object)
    R = Residual(r, np.full(len(r), FLOOR_M), np.array(parts["channel"], dtype=object),
                 np.concatenate(parts["station"]), phase, tt, (np.floor(tt / 2.0) % 2).astype(int),
                 np.array(parts["band"], dtype=object), (t, d), None, ob)
    return ob, R


def test_channel_x_phase_puts_a_known_offset_in_its_one_cell():
    ob, R = _doublet()
    cp = where_map(ob, R)["channel_phase"]
    assert cp["rows"] == ["drogue x", "drogue y", "drogue z", "hose"]
    assert cp["cols"] == [p[0] for p in PHASES]
    g = np.array(cp["gap_m"], float)
    expect = np.zeros_like(g)
    expect[2, 1] = OFFSET_M                      # every drogue z component of the doublet is off by it
    expect[3, 1] = 1.0 / np.sqrt(3)              # the hose's one doublet window: 1 m at one of three stations
    # exact arithmetic on the hand-built components: only rounding error
    assert_allclose(g, expect, atol=1e-12)
    assert_allclose(np.array(cp["floor_m"], float), FLOOR_M, rtol=1e-12)
    # 20 bins of 0.25 s in the 5 s doublet, 40 in the 10 s free response
    assert cp["n"][2] == [20, 20, 40]


def test_station_x_band_of_the_hose_groups_stations_by_three_metres():
    ob, R = _doublet()
    sb = where_map(ob, R)["station_band"]
    assert sb["rows"] == ["0 to 3 m", "3 to 6 m", "6 to 9 m"] and sb["cols"] == ["below 0.5 Hz"]
    # one of the four windows at 3-6 m is 1 m off: RMS 1/2 m
    assert_allclose(np.array(sb["gap_m"], float).ravel(), [0.0, 0.5, 0.0], atol=1e-12)
    assert sb["n"] == [[4], [4], [4]]


def test_overlay_series_is_thinned_and_the_simulation_is_the_log_minus_the_residual():
    ob, R = _doublet()
    s = where_map(ob, R)["series"]
    assert s["kind"] == "drogue" and len(s["t_s"]) <= OVERLAY_POINTS
    t = np.array(s["t_s"])
    dz = np.array(s["log"]["z"]) - np.array(s["sim"]["z"])
    # the series are rounded to 0.1 mm; a thinning bin straddling 5 s or 10 s averages both sides
    inside = (t > 5.1) & (t < 9.9)
    outside = (t < 4.9) | (t > 10.1)
    assert_allclose(dz[inside], OFFSET_M, atol=2e-4)
    assert_allclose(dz[outside], 0.0, atol=2e-4)


def _with_new_where_maps(js: dict, before: dict | None = None) -> dict:
    """The committed diagnosis with its doublet family's where-maps replaced by
    the hand-built one's (as a new diagnose writes them), or the baseline's by
    `before`."""
    js = copy.deepcopy(js)
    if before is None:
        before = where_map(*_doublet())
    before = json.loads(json.dumps(before))
    ob, R = _doublet(0.0)
    after = json.loads(json.dumps(where_map(ob, R)))
    fam = next(k for k in js["families"] if k.startswith("pitch_doublet"))
    d = js["families"][fam]
    d["gap"] = {"PD-TEST": before}
    d["gap_after_best"] = {"PD-TEST": after}
    return {**js, "families": {fam: d}}


def _without_new_where_maps(js: dict) -> dict:
    """The committed diagnosis as a diagnose from before the where-map tables
    and series wrote it."""
    js = copy.deepcopy(js)
    for d in js["families"].values():
        for key in ("gap", "gap_after_best"):
            for w in (d.get(key) or {}).values():
                for new in ("channel_phase", "station_band", "series"):
                    w.pop(new, None)
    return js


def test_report_renders_an_old_diagnosis_json_with_a_note_and_a_new_one_with_its_figures():
    old = _without_new_where_maps(json.loads((ROOT / "reports" / "diagnose" / "diagnosis.json").read_text()))
    html = diagnosis_html(old)
    assert "predates the channel x phase" in html
    new = _with_new_where_maps(old)   # the doublet family alone, with the hand-built where-maps
    html = diagnosis_html(new)
    assert "predates" not in html
    srcs = re.findall(r'<img src="([^"]*)"', html)
    # ranking, where-map, before/after; per log the heat maps and the overlay
    assert len(srcs) == 3 + 2
    assert "PD-TEST: the gap by channel and test phase and along the hose by band, before and after" in html
    assert "the drogue&#x27;s z (its largest gap)" in html or "the drogue's z (its largest gap)" in html


def test_report_draws_a_split_whose_every_component_was_left_out_as_a_blank_cell():
    """The reproducibility weights leave a component out with its floor
    (`evaluate.evaluate`): a channel all of whose components are left out has
    gap 0 over floor 0, and a quiet phase too short for a band has no floor.
    Both are blank cells, not a division by zero (measured on a
    proving-ground doublet's tracker-phase signature)."""
    ob, R = _doublet()
    out = R.channel == "drogue y"
    R = dataclasses.replace(R, r=np.where(out, 0.0, R.r), floor=np.where(out, 0.0, R.floor))
    w = where_map(ob, R)
    assert w["by_channel"]["drogue y"] == {"gap_m": 0.0, "floor_m": 0.0, "real": False}
    w["by_band"]["drogue x"]["fundamental"].update(residual_m=None, floor_m=None)
    js = json.loads((ROOT / "reports" / "diagnose" / "diagnosis.json").read_text())
    html = diagnosis_html(_with_new_where_maps(js, w))
    assert "where the baseline&#x27;s gap lies" in html or "where the baseline's gap lies" in html
