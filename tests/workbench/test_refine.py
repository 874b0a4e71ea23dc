"""Form parameters (`Effect.refined`): searched once their effect is selected,
never when it competes to enter. The registry's entry, the calibrator with a
refined setup, the selection's refinement step and its verdict, the hold for
a centre-line tow point, and a validation variant's `refine`. Synthetic
residuals and scorers stand in for the simulation, as in test_select."""
import math
import types
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from solver.effects import EFFECTS
from workbench.cases import load_case
from workbench.diagnosis import fit as F
from workbench.diagnosis import select as SEL
from workbench.diagnosis.fit import EffectCalibrator, effects_at
from workbench.diagnosis.report import _selection_blocks
from workbench.diagnosis.result import Candidate
from workbench.diagnosis.setup import PARAM_PENALTY, Setup, calibrated_params, refinable
from workbench.errors import InputError

SPAN = ("tanker_wake", "lateral_offset_m")


def test_the_wakes_span_position_is_a_form_parameter_not_calibrated_at_entry():
    wake = EFFECTS["tanker_wake"]
    assert wake.calibrated == ["strength"] and wake.refined == ["lateral_offset_m"]
    p = wake.params["lateral_offset_m"]
    assert p.lo <= p.search[0] < p.off < p.search[1] <= p.hi
    # entering, the wake competes with its strength alone; refined, its span position follows it
    assert [n for _, n, _ in calibrated_params(("tanker_wake", "drogue_lift"))] == ["strength", "scale"]
    assert [n for _, n, _ in calibrated_params(("tanker_wake", "drogue_lift"), (SPAN,))] == \
        ["strength", "lateral_offset_m", "scale"]
    # a refined pair of an effect not in the candidate adds nothing
    assert [n for _, n, _ in calibrated_params(("drogue_lift",), (SPAN,))] == ["scale"]
    assert effects_at(("tanker_wake", "drogue_lift"), [1.2, -3.0, 0.5], (SPAN,)) == \
        {"tanker_wake": {"strength": 1.2, "lateral_offset_m": -3.0}, "drogue_lift": {"scale": 0.5}}


@pytest.mark.parametrize("tanker, pairs", [("kdc10", (SPAN,)), ("g3", ()), (None, (SPAN,))])
def test_the_span_position_is_held_for_a_tow_point_on_the_centre_line(tanker, pairs):
    # hardware.toml: the KDC-10's pod at 16.5 m span station, the G-III's buddy store at 0
    assert refinable({"hardware": {"tanker": tanker}}) == pairs


TRUTH = {"strength": 1.5, "lateral_offset_m": -2.5}
T = np.linspace(0.0, 10.0, 300)


def test_a_refined_setup_fits_the_form_parameter_from_a_warm_start(monkeypatch):
    # a residual in the wake's strength and (bent) span position: entering, the span
    # position is held at its off value; refined, the warm-started fit finds both
    def evaluate(path, effects, setup):
        w = effects.get("tanker_wake", {})
        s, y = w.get("strength", 0.0), w.get("lateral_offset_m", 0.0)
        r = (np.sin(T) * (s - TRUTH["strength"]) + np.cos(2 * T) * (math.tanh(y / 3) - math.tanh(TRUTH[
            "lateral_offset_m"] / 3)) + np.random.default_rng(len(path)).normal(0.0, 1e-3, T.size))
        return types.SimpleNamespace(r=r, segment=np.zeros(T.size, int), floor=np.full(T.size, 1e-3),
                                     channel=np.full(T.size, "drogue y"))
    monkeypatch.setattr(F, "evaluate", evaluate)
    entered = EffectCalibrator(("tanker_wake",)).fit(["a", "bb"])
    assert entered.params_ == {"tanker_wake": {"strength": pytest.approx(entered.x_[0])}}
    refined = EffectCalibrator(("tanker_wake",), Setup(refined=(SPAN,))).fit(["a", "bb"], start=entered.params_)
    for k, v in TRUTH.items():
        assert abs(refined.params_["tanker_wake"][k] - v) <= 3 * refined.stderr_["tanker_wake"][k], k
    assert refined.gap_train_ < 0.2 * entered.gap_train_


def _scorer(floor: float, form: float, jobs: list, remainder: float = 0.0):
    """A held-out gap of the noise floor, what no effect explains
    (`remainder`), the wake's and the lift's parts (1.0 and 0.5, gone once
    the effect is in the set) and a form part `form` that only the wake with
    its span position refined explains."""
    def score(job):
        paths, cand, setup, warm = job
        jobs.append(job)
        n = len(calibrated_params(cand, setup.refined))
        parts = [remainder, 0.0 if "tanker_wake" in cand else 1.0, 0.0 if "drogue_lift" in cand else 0.5,
                 0.0 if ("tanker_wake" in cand and SPAN in setup.refined) else form]
        g = math.sqrt(floor ** 2 + sum(a ** 2 for a in parts))
        x = [0.5] * n
        return Candidate("+".join(cand), list(cand), n, params=effects_at(cand, x, setup.refined),
                         param_stderr=effects_at(cand, [0.01] * n, setup.refined), gap_after_heldout=g,
                         gap_after_train=g, folds=[{"held_out": "L1", "params": x, "gap_train": g, "gap_heldout": g}])
    return score


def _select(form, refinable_pairs=(SPAN,), floor=0.01, remainder=0.0):
    jobs = []
    g0 = math.sqrt(floor ** 2 + remainder ** 2 + 1.0 + 0.25 + form ** 2)
    sel = SEL.forward_select(["L1"], ["tanker_wake", "drogue_lift", "drogue_drag"], Setup(),
                             lambda fn, js, progress=None: [fn(j) for j in js], g0, floor,
                             score=_scorer(floor, form, jobs, remainder), refinable=refinable_pairs)
    return sel, g0, jobs


def test_a_form_parameter_that_earns_its_place_is_refined_on_the_selected_set():
    sel, g0, jobs = _select(form=0.3)
    refine = next(s for s in sel.steps if "refined" in s)
    assert refine["refined"] == "tanker_wake.lateral_offset_m" and refine["accepted"] and refine["new_params"] == 1
    # after forward selection stopped, on the set it selected, warm-started from its fit
    assert [s["added"] for s in sel.steps if s.get("accepted") and "added" in s] == ["tanker_wake", "drogue_lift"]
    assert sel.steps[refine["step"] - 2]["added"] == "drogue_drag" and not sel.steps[refine["step"] - 2]["accepted"]
    before = next(c for c in sel.fitted if c.step == 2 and c.effects == ["tanker_wake", "drogue_lift"])
    job = next(j for j in jobs if SPAN in j[2].refined)
    assert job[1] == ("tanker_wake", "drogue_lift") and job[3]["all"] == before.params
    assert all(not j[2].refined for j in jobs[:jobs.index(job)])
    assert sel.chosen.params["tanker_wake"] == {"strength": 0.5, "lateral_offset_m": 0.5}
    assert sel.refined == (SPAN,) and sel.to_json()["refined"] == ["tanker_wake.lateral_offset_m"]
    assert_allclose(sel.chosen.gap_after_heldout, 0.01)
    # the refinement's gain is the wake's; the shares still add up to the shrink
    assert_allclose(sum(sel.chosen.shares.values()), 1.0 - sel.chosen.gap_after_heldout / g0, rtol=1e-12)
    assert_allclose(sel.chosen.shares["tanker_wake"], (g0 - math.sqrt(0.01 ** 2 + 0.25 + 0.09)
                                                       + refine["gain_m"]) / g0, rtol=1e-12)
    # backward elimination fits without each event over the refined setup
    assert all(SPAN in j[2].refined for j in jobs[jobs.index(job) + 1:])
    # the report's table says what the step did
    table, _ = _selection_blocks({"selection": sel.to_json()})
    assert "refined: tanker_wake.lateral_offset_m" in [r[1].text for r in table.rows]


def test_a_form_parameter_that_buys_less_than_its_penalty_is_left_at_its_off_value():
    # beside a remainder no effect explains, a form part that cuts the gap by less than
    # one parameter's penalty (PARAM_PENALTY of the gap left) though it explains 30 x
    # the noise floor
    sel, _, _ = _select(form=0.03, floor=0.001, remainder=1.0)
    refine = next(s for s in sel.steps if "refined" in s)
    assert refine["gain_m"] < PARAM_PENALTY * refine["gap_heldout_before_m"]
    assert not refine["accepted"] and sel.refined == ()
    assert "lateral_offset_m" not in sel.chosen.params["tanker_wake"]
    refit = next(c for c in sel.fitted if c.step == refine["step"])
    assert "refining tanker_wake.lateral_offset_m refused" in refit.why_not_first


def test_nothing_is_refined_where_the_hardware_holds_the_form_or_its_effect_is_not_selected():
    sel, _, jobs = _select(form=0.3, refinable_pairs=())
    assert not any("refined" in s for s in sel.steps) and all(not j[2].refined for j in jobs)
    sel, _, jobs = _select(form=0.3, refinable_pairs=(("bow_wave", "strength"),))
    assert not any("refined" in s for s in sel.steps)


def _trail_case(tmp_path, variant: str):
    src = (Path(__file__).resolve().parents[2] / "cases" / "kdc10_trail.toml").read_text()
    src += f"\n[[variants]]\nid = \"probe\"\n{variant}\n"
    p = tmp_path / "case.toml"
    p.write_text(src)
    return p


def test_a_variant_refines_only_a_form_parameter_of_an_effect_it_calibrates(tmp_path):
    ok = 'calibrate = ["tanker_wake"]\ncalibrate_on = ["TR-KDC10-E7"]\nrefine = ["tanker_wake.lateral_offset_m"]'
    case = load_case(_trail_case(tmp_path, ok))
    assert case["variants"][-1]["refine"] == ["tanker_wake.lateral_offset_m"]
    for bad in ('calibrate = ["drogue_lift"]\ncalibrate_on = ["TR-KDC10-E7"]\nrefine = ["tanker_wake.lateral_offset_m"]',
                'calibrate = ["tanker_wake"]\ncalibrate_on = ["TR-KDC10-E7"]\nrefine = ["tanker_wake.strength"]'):
        with pytest.raises(InputError, match=r"refine: .* no form parameter of a calibrated effect"):
            load_case(_trail_case(tmp_path, bad))


def test_a_variants_refine_reaches_its_calibration_with_its_effect(tmp_path, monkeypatch):
    import workbench.validation as V
    seen = []

    class Recorder:
        def __init__(self, effects, setup):
            seen.append((tuple(effects), setup.refined))

        def fit(self, paths, start=None):
            self.params_, self.stderr_, self.gap_train_, self.gap_before_ = {}, {}, 0.0, 1.0
            return self
    monkeypatch.setattr(V, "EffectCalibrator", Recorder)
    case = load_case(_trail_case(tmp_path, 'calibrate = ["drogue_lift", "tanker_wake"]\ncalibrate_on = '
                                           '["TR-KDC10-E7"]\nrefine = ["tanker_wake.lateral_offset_m"]'))
    V.calibrate_variant(case, case["variants"][-1], ["TR-KDC10-E7.mcap"])
    # one effect more at a time, the form parameter fitted with its effect once that is in
    assert seen == [(("drogue_lift",), (SPAN,)), (("drogue_lift", "tanker_wake"), (SPAN,))]
    assert [n for _, n, _ in calibrated_params(seen[0][0], seen[0][1])] == ["scale"]
