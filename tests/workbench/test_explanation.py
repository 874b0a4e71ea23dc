"""What an explanation names: events, apart from model form and from
calibrations within a data sheet's tolerance (`workbench.diagnosis.explanation`)."""
from __future__ import annotations

import numpy as np
from hypothesis import given, strategies as st

from solver.effects import EFFECTS
from workbench.diagnosis.explanation import calibration, explain, within_tolerance
from pathlib import Path

import pytest

from workbench.diagnosis import rank as RK
from workbench.diagnosis.evaluate import record
from workbench.diagnosis.setup import Setup, applicable
from workbench.parallel import Mapper
from workbench.diagnosis.result import Candidate, FamilyDiagnosis

FLIGHT = Path(__file__).resolve().parents[2] / "flighttest" / "logs" / "flight"
TOL = EFFECTS["drogue_lift"].params["scale"].tolerance


def test_every_tolerance_is_on_a_calibrated_factor_and_inside_its_search():
    toleranced = [(e, k, p) for e, eff in EFFECTS.items() for k, p in eff.params.items() if p.tolerance is not None]
    assert {e for e, _, _ in toleranced} == {"drogue_lift", "drogue_drag", "hose_drag", "hose_stiffness"}
    for e, k, p in toleranced:
        assert k in EFFECTS[e].calibrated and p.off == 1.0, (e, k)
        # the search reaches beyond the tolerance on both sides: an effect beyond it can be fitted
        assert 0.0 < p.tolerance and p.search[0] < 1.0 - p.tolerance and 1.0 + p.tolerance < p.search[1], (e, k)


@given(st.floats(0.0, 3.0))
def test_a_factor_is_a_calibration_exactly_when_within_its_tolerance(v):
    why = calibration("drogue_lift", {"scale": v})
    # to the round-off (1e-9 of the factor): far below any fit's standard error
    assert (why is not None) == (round(abs(v - 1.0), 9) <= TOL)
    if why:
        assert "drogue_lift.scale" in why and f"{100 * TOL:.0f} %" in why


@pytest.mark.parametrize("effect, name", [("drogue_lift", "scale"), ("drogue_drag", "scale"),
                                          ("hose_drag", "crossflow"), ("hose_stiffness", "bending")])
def test_a_factor_at_its_tolerance_is_within_it_whatever_the_round_off(effect, name):
    # 1 + 0.1 is 1.1000000000000001 in binary, |1.1 - 1| 0.10000000000000009: a
    # factor drawn at the clip of a spread equal to its tolerance (the proving
    # ground's) is at the tolerance, for the diagnosis and the scoring alike
    p = EFFECTS[effect].params[name]
    for f in (1.0 + p.tolerance, 1.0 - p.tolerance):
        assert within_tolerance(p, f, 1.0) and calibration(effect, {name: f}) is not None
        assert not within_tolerance(p, f + 1e-6 * np.sign(f - 1.0), 1.0)
    assert within_tolerance(p, 1.0, 1.0)


def test_effects_without_a_data_sheet_value_are_never_calibrations():
    assert calibration("steady_wind", {"vertical_mps": 0.01, "lateral_mps": 0.0}) is None
    assert calibration("sensor_lag", {"delay_s": 0.0}) is None
    assert calibration("drogue_reference", {"offset_m": 0.0}) is None


def test_a_calibration_beside_an_event_is_not_named():
    named, cals = explain(["drogue_lift", "steady_wind"],
                          {"drogue_lift": {"scale": 1.0 + 0.5 * TOL}, "steady_wind": {"vertical_mps": 2.0}})
    assert named == ["steady_wind"] and list(cals) == ["drogue_lift"]


def test_a_calibration_alone_is_named_and_model_form_never_is():
    named, cals = explain(["drogue_lift", "drogue_reference"],
                          {"drogue_lift": {"scale": 1.0 - 0.5 * TOL}, "drogue_reference": {"offset_m": 0.2}})
    assert named == ["drogue_lift"] and list(cals) == ["drogue_lift"]
    assert explain(["drogue_reference"], {"drogue_reference": {"offset_m": 0.2}}) == ([], {})
    assert explain([], {}) == ([], {})


def test_an_effect_beyond_its_tolerance_is_an_event():
    named, cals = explain(["drogue_lift", "drogue_drag"],
                          {"drogue_lift": {"scale": 0.2}, "drogue_drag": {"scale": 1.6}})
    assert named == ["drogue_lift", "drogue_drag"] and cals == {}


def _family(top: Candidate) -> FamilyDiagnosis:
    none = Candidate("none", [], 0, gap_after_heldout=0.3, probability=0.0)
    return FamilyDiagnosis(family="trail/kdc10/kdc10_pod", kind="trail", logs=["a"], n_elements=20,
                           gap_definition="", gap_before=0.3, noise_floor=0.01, gap_real=True, held_out_scheme="",
                           screen={}, not_applicable={}, ranking=[top, none], failed=[],
                           remaining_unexplained={"gap_m": 0.05, "above_noise_m": 0.049}, gap={},
                           gap_after_best={}, wall_s=1.0)


def test_findings_json_and_report_say_which_member_is_a_calibration():
    from workbench.diagnosis.findings import findings
    from workbench.diagnosis.report import _effect_cell
    params = {"drogue_lift": {"scale": 0.9}, "steady_wind": {"vertical_mps": 2.0, "lateral_mps": 1.0}}
    top = Candidate("drogue_lift+steady_wind", ["drogue_lift", "steady_wind"], 3, params=params,
                    param_stderr={e: {k: 0.01 for k in d} for e, d in params.items()}, gap_before=0.3,
                    gap_after_heldout=0.05, shrink_heldout=5 / 6, probability=0.9, folds=[])
    top.named, top.calibrations = explain(top.effects, top.params)
    d = _family(top)
    text = "\n".join(findings(d))
    assert "not named as an unmodelled effect" in text and "the explanation names steady_wind" in text
    j = d.to_json()["ranking"][0]
    assert j["named"] == ["steady_wind"] and set(j["calibrations"]) == {"drogue_lift"}
    assert "(within data-sheet tolerance: drogue_lift)" in _effect_cell(j).text


def test_findings_say_when_the_only_explanation_is_within_the_data_sheet():
    from workbench.diagnosis.findings import findings
    top = Candidate("drogue_drag", ["drogue_drag"], 1, params={"drogue_drag": {"scale": 1.05}},
                    param_stderr={"drogue_drag": {"scale": 0.01}}, gap_before=0.3, gap_after_heldout=0.05,
                    shrink_heldout=5 / 6, probability=0.9, folds=[])
    top.named, top.calibrations = explain(top.effects, top.params)
    assert top.named == ["drogue_drag"]
    assert any("the hardware's own spread about its data sheet" in s for s in findings(_family(top)))


def test_generated_factor_effects_lie_beyond_the_data_sheets_tolerance():
    # the proving ground's events must be events by the diagnosis's own
    # definition: a drawn factor inside the tolerance would be data-sheet scatter
    from workbench.proving.generate import DRAWS
    rng = np.random.default_rng(3)
    for name in ("drogue_lift", "drogue_drag", "hose_drag", "hose_stiffness"):
        for _ in range(200):
            assert calibration(name, DRAWS[name](rng, 30.0)) is None, name


def test_forward_selection_draws_on_every_applicable_effect_however_low_it_screens(monkeypatch):
    # the screen orders the pool, it does not cut it: a local signature (the bow
    # wave before contact) screens low beside a steady offset
    seen = {}

    class Stop(Exception):
        pass

    def capture(paths, pool, *args, **kw):
        seen["pool"] = list(pool)
        raise Stop
    monkeypatch.setattr(RK, "forward_select", capture)
    path = str(FLIGHT / "TR-KDC10-E7.mcap")
    with pytest.raises(Stop):
        RK.diagnose_family([path], Setup(), mapper=Mapper(workers=1))
    rec = record(path)
    applicable_here = {e for e in EFFECTS if applicable(e, "trail", Setup().case_for(rec), rec) is None}
    assert set(seen["pool"]) == applicable_here and "drogue_reference" in seen["pool"]
