"""The one comparison (`flighttest.residual`, `flighttest.compare`) against
answers known by construction: a log against itself, against itself with the
drogue or the hose moved by a known amount, and the hose projection against
`metrics.shape_error` (the polyline projection's own statistics)."""
from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal

from flighttest import make_record, read_record
from flighttest import metrics as M
from flighttest.compare import Comparison, compare
from flighttest.residual import DROGUE, observe, residual
from flighttest.signatures import CHANNEL

LOGS = Path(__file__).resolve().parents[2] / "flighttest" / "logs" / "flight"
LOG_OF_KIND = {"pitch_doublet": "PD-G3-1.mcap", "trail": "TR-KDC10-E7.mcap", "engagement": "EN-KDC10-E7.mcap"}
# exact arithmetic on equal inputs leaves rounding only: means of sums of ~1e3 terms of ~10 m
EXACT = 1e-9


def _seg_of(t):
    """The alternating BLOCK_S = 2 s segments."""
    return np.floor(np.asarray(t, float) / 2.0).astype(int) % 2


@functools.lru_cache(maxsize=None)
def _log(kind):
    return read_record(LOGS / LOG_OF_KIND[kind])


@functools.lru_cache(maxsize=None)
def _observed(kind):
    return observe(_log(kind))


def _moved(rec, drogue=(0.0, 0.0, 0.0), when=None, hose_dz=0.0):
    """`rec` with its tracked drogue moved by `drogue` (m; only at times where
    `when(t)` holds, if given) and its video hose raised by `hose_dz`."""
    topics = dict(rec.topics)
    ors = rec.topics["/ors/drogue"].copy()
    sel = np.ones(len(ors), bool) if when is None else when(ors.index.to_numpy(float))
    for c, v in zip(("x_m", "y_m", "z_m"), drogue):
        ors.loc[sel, c] = ors.loc[sel, c] + v
    topics["/ors/drogue"] = ors
    if "/video/hose" in topics:
        h = rec.topics["/video/hose"].copy()
        h["z_m"] = h["z_m"] + hose_dz
        topics["/video/hose"] = h
    return make_record(rec.info, topics, rec.start_time_ns)


@pytest.mark.parametrize("kind", sorted(LOG_OF_KIND))
def test_a_log_against_itself_leaves_no_residual_and_no_error(kind):
    rec = _log(kind)
    R = residual(_observed(kind), rec)
    assert len(R.r) > 0
    assert_allclose(R.r, 0.0, atol=EXACT)
    assert np.all(np.isfinite(R.floor)) and np.all(R.floor >= 0.0)
    cmp = compare(rec, rec)
    assert isinstance(cmp, Comparison) and cmp.kind == kind
    errors = {k: v for k, v in cmp.metrics.items() if k.endswith(("_error_m", "_error_pct")) and v is not None}
    assert errors, "the comparison names no error metric"
    assert_allclose(list(errors.values()), 0.0, atol=EXACT, err_msg=str(sorted(errors)))
    frame = cmp.to_pandas()
    assert frame.name == rec.info.test_id and set(errors) <= set(frame.index)


def test_a_drogue_offset_in_one_phase_shows_in_that_channel_and_phase_only():
    rec = _log("pitch_doublet")
    ob = _observed("pitch_doublet")
    name, a, b = next(p for p in ob.phases if p[0] == "free response")
    # the simulated drogue 0.3 m higher over the free response (the tracker's fixes
    # are the simulated samples, so every bin lies wholly in or out of the window
    # except the bins straddling its ends)
    R = residual(ob, _moved(rec, (0.0, 0.0, 0.3), when=lambda t: (t >= a) & (t < b)))
    df = R.to_pandas()
    # the drogue's channels (a step over one phase moves the whole doublet's
    # phase fit too: the signature components are tested in test_signatures)
    df = df[df["channel"] != CHANNEL]
    lo, hi = df["t_s"] - 0.125, df["t_s"] + 0.125     # each bin's span (BIN_S = 0.25 s)
    within = (lo >= a) & (hi < b)
    outside = (hi < a) | (lo >= b)
    z = df["channel"] == "drogue z"
    assert within[z].sum() > 10
    assert_allclose(df.loc[z & within, "residual_m"], -0.3, atol=EXACT)
    assert (df.loc[z & within, "phase"] == name).all()
    assert_allclose(df.loc[outside | ~z, "residual_m"].where(~(z & ~outside), 0.0), 0.0, atol=EXACT)


def test_a_trail_drogue_offset_and_a_raised_hose_give_those_offsets():
    rec = _log("trail")
    R = residual(_observed("trail"), _moved(rec, (0.2, 0.0, 0.0)))
    df = R.to_pandas()
    assert_allclose(df.loc[df["channel"] == "drogue x", "residual_m"], -0.2, atol=EXACT)
    assert_allclose(df.loc[df["channel"].isin(["drogue y", "drogue z", "hose"]), "residual_m"], 0.0, atol=EXACT)
    # the simulated hose raised by dz: each log point lies dz cos(slope) below
    # it, the slope of the simulated segment its foot falls on; at equal x exactly dz
    dz = 0.1
    R = residual(_observed("trail"), _moved(rec, hose_dz=dz))
    h = R.hose[R.hose["inside"]]
    assert len(h) > 10
    video = rec.topics["/video/hose"]
    steepest = 0.0
    for seg in (0, 1):      # the simulated line of a segment: the mean shape of its points
        shp = M.mean_shape(*(video[_seg_of(video["t_s"]) == seg][c] for c in ("x_m", "z_m")))
        steepest = max(steepest, np.max(np.abs(np.diff(shp["z_m"]) / np.diff(shp["x_m"]))))
    assert np.all(h["normal_m"] <= -dz * math.cos(math.atan(steepest)) + EXACT)
    assert np.all(h["normal_m"] >= -dz - EXACT)
    assert_allclose(h["vertical_m"].dropna(), -dz, atol=EXACT)
    # validation's trail shape error is the RMS of those same hose components
    shape = compare(rec, _moved(rec, hose_dz=dz)).metrics["trail_shape_rms_error_m"]
    assert_allclose(shape, np.sqrt(np.mean(R.r[R.channel == "hose"] ** 2)), rtol=1e-12)


def test_the_engagement_hose_normals_are_the_polyline_projection_of_each_frame():
    """Every video point's normal distance, station and `inside` equal
    `metrics.shape_error` of its frame against the simulated frame it is
    compared with (here a log raised by 0.1 m, so the distances are not zero)."""
    rec = _log("engagement")
    sim = _moved(rec, hose_dz=0.1)
    R = residual(_observed("engagement"), sim)
    hose, shim = rec.topics["/video/hose"], sim.topics["/video/hose"]
    frames = np.unique(hose["t_s"])
    for tf in frames[:: max(len(frames) // 25, 1)]:
        fr = hose[hose["t_s"] == tf]
        sf = shim[shim["t_s"] == tf].sort_values("point")
        se = M.shape_error(fr["x_m"], fr["z_m"], sf["x_m"], sf["z_m"])
        got = R.hose[R.hose["t_s"] == tf]
        assert_allclose(got["normal_m"], se.normal_error_m, atol=EXACT)
        assert_allclose(got["station_m"], se.station_m, atol=EXACT)
        assert_array_equal(got["inside"], se.inside)


def test_a_one_frame_static_record_is_compared_with_every_segment():
    """A static solution's one frame stands for the simulated line of both
    segments: the log's mean shape against it, however far in time."""
    rec = _log("trail")
    h = rec.topics["/video/hose"]
    line = h[h["t_s"] == h["t_s"].iloc[0]].sort_values("point")
    fixes = rec.tracker_fixes()
    end = fixes[["x_m", "y_m", "z_m"]].median().to_numpy()
    static = make_record(rec.info, {
        "/ors/drogue": pd.DataFrame({"x_m": [end[0]], "y_m": [end[1]], "z_m": [end[2]], "valid": [True]},
                                    index=pd.Index([0.0], name="t_s")),
        "/video/hose": line.assign(t_s=0.0)}, rec.start_time_ns)
    R = residual(_observed("trail"), static)
    assert set(R.segment) == {0, 1}
    for seg in (0, 1):
        pts = h[_seg_of(h["t_s"]) == seg]
        shp = M.mean_shape(pts["x_m"], pts["z_m"], bin_m=1.0)
        se = M.shape_error(shp["x_m"], shp["z_m"], line["x_m"], line["z_m"])
        hose = (R.segment == seg) & (R.channel == "hose")
        assert_allclose(R.r[hose], se.normal_error_m, atol=EXACT)
        assert_allclose(R.station[hose], shp["x_m"], atol=EXACT)
        dz = R.r[(R.segment == seg) & (R.channel == "drogue z")]
        assert_allclose(dz, np.median(fixes["z_m"][_seg_of(fixes.index) == seg]) - end[2], atol=EXACT)


@settings(max_examples=12, deadline=None)
@given(kind=st.sampled_from(sorted(LOG_OF_KIND)),
       d=st.tuples(*[st.floats(-2.0, 2.0, allow_nan=False)] * 3),
       dz=st.floats(-1.0, 1.0, allow_nan=False),
       delay=st.floats(0.0, 0.3, allow_nan=False))
def test_the_residual_s_shape_labels_and_floors_do_not_depend_on_the_simulation(kind, d, dz, delay):
    """Whatever the simulation does, the residual has the same components with
    the same tags (the least squares needs a fixed-length vector), every value
    and floor finite, the tags from their sets; a constant drogue offset shows
    as minus itself, and leaves the floors (the spread about each average)
    as they were, where no delay moves the fixes."""
    rec = _log(kind)
    ob = _observed(kind)
    base = residual(ob, rec)
    R = residual(ob, _moved(rec, d, hose_dz=dz), delay_s=delay if kind != "trail" else 0.0)
    assert len(R.r) == len(base.r)
    for name in ("channel", "phase", "segment", "band", "t"):
        assert_array_equal(getattr(R, name), getattr(base, name), err_msg=name)
    assert_array_equal(R.station, base.station)
    assert np.all(np.isfinite(R.r)) and np.all(np.isfinite(R.floor)) and np.all(R.floor >= 0)
    assert set(R.channel) <= {"hose", CHANNEL, *DROGUE}
    assert set(R.phase) <= {p[0] for p in ob.phases}
    assert set(R.segment) <= {0, 1}
    # stations: along the hose for its components and the curvature signatures, none for the drogue's
    along = (R.channel == "hose") | np.char.startswith(R.band.astype(str), "hose curvature")
    assert np.all(np.isnan(R.station[~along])) and np.all(np.isfinite(R.station[along]))
    df = R.to_pandas()
    assert list(df.columns) == ["channel", "station_m", "phase", "t_s", "segment", "band", "residual_m", "floor_m"]
    assert len(df) == len(R.r)
    if kind == "trail" or delay == 0.0:
        for c, name in enumerate(DROGUE):
            assert_allclose(R.r[R.channel == name], -d[c], atol=EXACT)
        if dz == 0.0:
            # the one-pass variance E[y^2] - E[y]^2 keeps sqrt(eps) |y| ~ 1e-7 m of y ~ 10 m
            assert_allclose(R.floor, base.floor, atol=1e-6)
    assert math.isfinite(R.gap) and math.isfinite(R.noise_floor)


@settings(max_examples=8, deadline=None)
@given(kind=st.sampled_from(sorted(LOG_OF_KIND)), offset=st.floats(-0.6, 0.6, allow_nan=False))
def test_a_tracked_point_aft_of_the_simulated_one_is_the_simulated_drogue_moved_aft(kind, offset):
    """`tracker_offset_m` (the drogue_reference effect) takes the offset off the
    log's fixes: the same residual, floors included, as a simulation whose
    drogue lies `offset` further aft; against the log itself, -offset in x."""
    rec = _log(kind)
    ob = _observed(kind)
    R = residual(ob, rec, tracker_offset_m=offset)
    moved = residual(ob, _moved(rec, (offset, 0.0, 0.0)))
    assert_allclose(R.r, moved.r, atol=EXACT)
    assert_allclose(R.floor, moved.floor, atol=1e-6)   # the one-pass variance's rounding, as above
    assert_allclose(R.r[R.channel == "drogue x"], -offset, atol=EXACT)
    assert_allclose(R.r[R.channel != "drogue x"], 0.0, atol=EXACT)


def test_the_trail_cross_stream_error_is_lateral_and_vertical_together():
    """3-4-5: the simulated drogue 0.3 m to starboard and 0.4 m up is 0.5 m off
    across the stream; its fore-aft offset does not count."""
    rec = _log("trail")
    m = compare(rec, _moved(rec, (0.7, 0.3, 0.4))).metrics
    assert_allclose([m["drogue_steady_y_error_m"], m["drogue_steady_z_error_m"]], [0.3, 0.4], atol=1e-9)
    assert_allclose(m["drogue_steady_cross_error_m"], 0.5, atol=1e-9)
