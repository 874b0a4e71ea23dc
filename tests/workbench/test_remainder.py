"""The model-form remainder (`workbench.diagnosis.remainder`) on residuals
built by hand: a steady offset of one sign and like size in every log is
model form; one of mixed sign, or in one log only, is not."""
from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from flighttest.residual import Residual
from workbench.diagnosis.remainder import remainder, sentences

FLOOR = 0.01   # m, every component's noise floor


def _residual(rng, dx, hose=(0.0, 0.0), n=120):
    """Drogue x, y, z components (0.005 m scatter) with drogue x offset by `dx`,
    and hose components at stations -1-6 m offset by hose[0], 6-12 m by hose[1]
    (a video point just forward of the tow point has a negative station)."""
    ch = np.repeat(["drogue x", "drogue y", "drogue z"], n)
    r = rng.normal(0.0, 0.005, 3 * n)
    r[:n] += dx
    st = np.full(3 * n, np.nan)
    hs = np.linspace(-1.0, 11.9, 40)
    hr = rng.normal(0.0, 0.005, 40) + np.where(hs < 6.0, hose[0], hose[1])
    ch = np.concatenate([ch, np.full(40, "hose")])
    r, st = np.concatenate([r, hr]), np.concatenate([st, hs])
    m = len(r)
    return Residual(r=r, floor=np.full(m, FLOOR), channel=ch, station=st, phase=np.full(m, "p"),
                    t=np.arange(m, dtype=float), segment=np.arange(m) % 2, band=np.full(m, "b"),
                    drogue=(None, None), hose=None, observation=None)


def test_a_steady_offset_in_every_log_is_model_form():
    rng = np.random.default_rng(3)
    rem = remainder({f"L{i}": _residual(rng, -0.2 + 0.01 * i, hose=(0.0, 0.08)) for i in range(3)})
    assert rem["drogue x"]["common"]
    # the mean of three logs' means of -0.2, -0.19, -0.18 (+ scatter 0.005/sqrt(120))
    assert_allclose(rem["drogue x"]["steady_m"], -0.19, atol=0.002)
    assert not rem["drogue y"]["common"] and not rem["drogue z"]["common"]
    # the hose's offset lies aft of 6 m only
    assert rem["hose stations"]["6 to 9 m"]["common"] and rem["hose stations"]["9 to 12 m"]["common"]
    assert not rem["hose stations"]["0 to 3 m"]["common"]
    said = sentences(rem, "drogue_lift")
    assert said[0].startswith("drogue x: -0.190 m steady in every log")
    assert any(s.startswith("hose at 6 to 9 m") for s in said)
    assert list(rem["hose stations"])[0] == "-3 to 0 m"


@pytest.mark.parametrize("offsets", [(-0.2, 0.2, -0.2), (-0.2, -0.02, -0.2), (-0.2,)])
def test_mixed_signs_unlike_sizes_or_one_log_are_not_model_form(offsets):
    rng = np.random.default_rng(4)
    rem = remainder({f"L{i}": _residual(rng, dx) for i, dx in enumerate(offsets)})
    assert not rem["drogue x"]["common"]
    assert not any("model-form" in s for s in sentences(rem, "x"))


def test_a_varying_remainder_is_said_against_the_noise():
    rng = np.random.default_rng(5)
    R = _residual(rng, 0.0)
    R.r[:120] += 0.1 * np.sin(np.linspace(0, 20, 120))   # 0.07 m RMS, 7 x the floor
    rem = remainder({"L0": R})
    assert rem["drogue x"]["per_log"]["L0"]["varying_real"]
    assert_allclose(rem["drogue x"]["varying_m"], 0.1 / np.sqrt(2), rtol=0.05)   # sine RMS, 0.005 scatter
    assert sentences(rem, "none")[0].startswith("drogue x: 0.07")


def test_the_remainder_reaches_the_findings_the_json_and_the_report():
    from workbench.diagnosis.findings import findings
    from workbench.diagnosis.report import _remainder_blocks
    from workbench.diagnosis.result import Candidate, FamilyDiagnosis
    rng = np.random.default_rng(6)
    rem = remainder({f"L{i}": _residual(rng, -0.2) for i in range(2)})
    none = Candidate("none", [], 0, gap_before=0.2, gap_after_heldout=0.2, shrink_heldout=0.0, score=0.2,
                     why="no effect earns its place")
    d = FamilyDiagnosis(family="trail/kdc10/kdc10_pod", kind="trail", logs=["L0", "L1"], n_elements=20,
                        gap_definition="", gap_before=0.2, noise_floor=0.01, gap_real=True, held_out_scheme="",
                        screen={}, not_applicable={}, ranking=[none], failed=[],
                        remaining_unexplained={"gap_m": 0.2, "above_noise_m": 0.2}, gap={}, gap_after_best={},
                        wall_s=0.0, remainder=rem)
    said = findings(d)
    assert any(s.startswith("drogue x: -0.200 m steady in every log") and "the baseline in" in s for s in said)
    assert d.to_json()["remainder"]["drogue x"]["common"] is True
    (table,) = _remainder_blocks(d.to_json())
    assert [r[0].text for r in table.rows][:3] == ["drogue x", "drogue y", "drogue z"]
    assert table.rows[0][4].text.startswith("model form")
