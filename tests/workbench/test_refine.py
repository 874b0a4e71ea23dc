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
from workbench.diagnosis.explanation import implausibility
from workbench.diagnosis.setup import PARAM_PENALTY, Setup, calibrated_params, refinable
from workbench.errors import InputError

SPAN = ("tanker_wake", "lateral_offset_m")
HEIGHT = ("tanker_wake", "vertical_offset_m")


def test_the_wakes_span_position_is_a_form_parameter_not_calibrated_at_entry():
    wake = EFFECTS["tanker_wake"]
    assert wake.calibrated == ["strength"] and wake.refined == ["vertical_offset_m", "lateral_offset_m"]
    for name in wake.refined:
        p = wake.params[name]
        assert p.lo <= p.search[0] < p.off < p.search[1] <= p.hi
    # entering, the wake competes with its strength alone; refined, its span position follows it
    assert [n for _, n, _ in calibrated_params(("tanker_wake", "drogue_lift"))] == ["strength", "scale"]
    assert [n for _, n, _ in calibrated_params(("tanker_wake", "drogue_lift"), (SPAN,))] == \
        ["strength", "lateral_offset_m", "scale"]
    # a refined pair of an effect not in the candidate adds nothing
    assert [n for _, n, _ in calibrated_params(("drogue_lift",), (SPAN,))] == ["scale"]
    assert effects_at(("tanker_wake", "drogue_lift"), [1.2, -3.0, 0.5], (SPAN,)) == \
        {"tanker_wake": {"strength": 1.2, "lateral_offset_m": -3.0}, "drogue_lift": {"scale": 0.5}}


@pytest.mark.parametrize("tanker, pairs", [("kdc10", (HEIGHT, SPAN)), ("g3", (HEIGHT,)), (None, (HEIGHT, SPAN))])
def test_the_span_position_is_held_for_a_tow_point_on_the_centre_line(tanker, pairs):
    # hardware.toml: the KDC-10's pod at 16.5 m span station, the G-III's buddy store at 0;
    # the sheet's height is refined on either: it descends behind the wing wherever the store
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


def _field_scorer(jobs: list, wind_gap: float = 0.3, values: dict | None = None, lift: float = 0.5):
    """A steady wind that explains the log only on its search bound (a flow
    the held wake's form cannot supply), a wake that explains it only with
    its sheet's height refined, and a lift part (`lift`) only the lift explains;
    the floor 0.01. Fitted values 0.5 but the wind's (6, its bound) and
    `values`' ({(effect, parameter): value})."""
    def score(job):
        paths, cand, setup, warm = job
        jobs.append(job)
        cal = calibrated_params(cand, setup.refined)
        x = [(values or {}).get((e, n), 6.0 if e == "steady_wind" else 0.5) for e, n, _ in cal]
        high = "tanker_wake" in cand and HEIGHT in setup.refined
        flow = 0.0 if high else (wind_gap if "steady_wind" in cand else 0.6 if "tanker_wake" in cand else 1.0)
        g = math.sqrt(0.01 ** 2 + flow ** 2 + (0.0 if "drogue_lift" in cand else lift) ** 2)
        return Candidate("+".join(cand), list(cand), len(cal), params=effects_at(cand, x, setup.refined),
                         param_stderr=effects_at(cand, [0.01] * len(cal), setup.refined), gap_after_heldout=g,
                         gap_after_train=g, folds=[{"held_out": "L1", "params": x, "gap_train": g, "gap_heldout": g}])
    return score


def _field_select(refinable_pairs, wind_gap=0.3, values=None, lift=0.5):
    jobs = []
    g0 = math.sqrt(0.01 ** 2 + 1.0 + lift ** 2)
    sel = SEL.forward_select(["L1"], ["tanker_wake", "steady_wind", "drogue_lift"], Setup(),
                             lambda fn, js, progress=None: [fn(j) for j in js], g0, 0.01,
                             score=_field_scorer(jobs, wind_gap, values, lift), refinable=refinable_pairs)
    return sel, jobs


def test_a_field_is_fitted_with_its_form_free_where_the_best_addition_stands_on_a_bound():
    # step 1's best addition is the steady wind on its 6 m/s bound: the wake is fitted
    # again with its sheet's height free there, and taken; then the lift
    sel, jobs = _field_select((HEIGHT, SPAN))
    added = [s["added"] for s in sel.steps if s.get("accepted") and "added" in s]
    assert added == ["tanker_wake", "drogue_lift"]
    refit = [j for j in jobs if j[2].refined]
    # in step 1, from step 1's own fit of it, with both of the hardware's form parameters
    held = next(c for c in sel.fitted if c.step == 1 and c.effects == ["tanker_wake"]
                and "vertical_offset_m" not in c.params["tanker_wake"])
    assert refit[0][1] == ("tanker_wake",) and refit[0][2].refined == (HEIGHT, SPAN)
    assert refit[0][3]["all"] == held.params
    assert set(sel.chosen.params["tanker_wake"]) == {"strength", "vertical_offset_m", "lateral_offset_m"}
    assert sel.refined == (HEIGHT, SPAN)
    assert_allclose(sel.chosen.gap_after_heldout, 0.01)
    # the held fit says why it gave way; the step's alternatives hold the steady wind
    assert "fitted again with tanker_wake.vertical_offset_m, tanker_wake.lateral_offset_m free" in held.why_not_first
    step1 = next(s for s in sel.steps if s["step"] == 1)
    assert step1["candidate"] == "tanker_wake" and "steady_wind" in step1["alternatives"]
    # every later fit of the wake carries the refined form, warm-started in its order;
    # nothing is left to refine at the end
    later = jobs[jobs.index(refit[0]) + 1:]
    assert later and all(j[2].refined == (HEIGHT, SPAN) for j in later)
    lift = next(j for j in later if j[1] == ("tanker_wake", "drogue_lift"))
    assert lift[3]["all"] == refit_params(sel)
    assert not any("refined" in s for s in sel.steps)


def refit_params(sel):
    return next(c for c in sel.fitted if c.step == 1 and "vertical_offset_m" in c.params.get("tanker_wake", {})).params


def test_no_field_is_refitted_where_the_best_addition_is_plausible_or_the_hardware_holds_its_form():
    # a wind that explains nothing is never the best: no refit in the steps; the selected
    # wake's form is refined once selection stops, as before
    sel, jobs = _field_select((HEIGHT, SPAN), wind_gap=2.0)
    forward = {s["step"] for s in sel.steps if "added" in s}
    assert not any("vertical_offset_m" in c.params.get("tanker_wake", {}) for c in sel.fitted if c.step in forward)
    assert sel.chosen.effects == ["tanker_wake", "drogue_lift"]
    assert next(s for s in sel.steps if "refined" in s)["refined"] == \
        "tanker_wake.vertical_offset_m, tanker_wake.lateral_offset_m"
    # the wind on its bound the best, but no form of the hardware's to free: the wind is
    # taken (no plausible addition comes near it)
    sel, jobs = _field_select(())
    assert all(not j[2].refined for j in jobs)
    assert "tanker_wake" not in sel.chosen.effects and "steady_wind" in sel.chosen.effects


def test_a_field_refit_that_cannot_beat_the_steps_bar_fitted_on_everything_is_not_scored_held_out():
    # the prefit (a fit on all logs, a lower bound of the held-out gap) of the refitted wake
    # misses the bar: no held-out scoring of it, and the wind on its bound is taken
    jobs, pre = [], []

    def prefit(job):
        pre.append(job)
        return 2.0
    g0 = math.sqrt(0.01 ** 2 + 1.0 + 0.25)
    sel = SEL.forward_select(["L1"], ["tanker_wake", "steady_wind", "drogue_lift"], Setup(),
                             lambda fn, js, progress=None: [fn(j) for j in js], g0, 0.01,
                             score=_field_scorer(jobs), refinable=(HEIGHT,), prefit=prefit)
    assert [j[1] for j in pre][:1] == [("tanker_wake",)] and pre[0][2].refined == (HEIGHT,)
    assert not any(j[2].refined for j in jobs)
    assert "steady_wind" in sel.chosen.effects


def test_a_calibration_on_its_bound_sends_no_field_to_be_refitted():
    # the lift, a calibration, is step 1's best addition on its bound 0 (the hardware off its
    # sheet, not a flow's stand-in); the wind never beats the held wake: no refit in the steps
    sel, jobs = _field_select((HEIGHT,), wind_gap=2.0, values={("drogue_lift", "scale"): 0.0}, lift=2.0)
    assert [s["added"] for s in sel.steps[:2]] == ["drogue_lift", "tanker_wake"]
    assert "on its search bound" in implausibility(next(c for c in sel.fitted if c.effects == ["drogue_lift"]))
    forward = {s["step"] for s in sel.steps if "added" in s}
    assert not any(HEIGHT in j[2].refined for j in jobs[:sum(1 for c in sel.fitted if c.step in forward)])


def test_a_form_parameter_left_on_its_bound_is_refused_and_the_rest_refined_without_it():
    # the wake selected with its sheet held; refined, the sheet's height ends on its -3 m bound:
    # that refinement is refused, and the span position is fitted again alone
    sel, jobs = _field_select((HEIGHT, SPAN), wind_gap=2.0, values={("tanker_wake", "vertical_offset_m"): -3.0})
    refines = [s for s in sel.steps if "refined" in s]
    assert [s["refined"] for s in refines] == ["tanker_wake.vertical_offset_m, tanker_wake.lateral_offset_m",
                                                "tanker_wake.lateral_offset_m"]
    assert not refines[0]["accepted"]
    first = next(c for c in sel.fitted if c.step == refines[0]["step"])
    assert "tanker_wake.vertical_offset_m = -3 on its search bound" in first.why_not_first
    assert [j[2].refined for j in jobs if j[2].refined][:2] == [(HEIGHT, SPAN), (SPAN,)]
    # in this scorer only the sheet's height cuts the flow part: the span position alone
    # earns no place, and the selected set keeps its held form
    assert not refines[1]["accepted"] and sel.refined == ()


def test_a_refitted_field_whose_step_is_refused_leaves_the_setup_as_it_was():
    # a flow part within the noise: the wind on its bound and the refitted wake each explain
    # less than twice the floor (the held wake fits worse than none), so the refitted wake,
    # the best, is refused; nothing is selected, and nothing is said to be refined
    floor = 0.01

    def score(job):
        paths, cand, setup, warm = job
        cal = calibrated_params(cand, setup.refined)
        x = [6.0 if e == "steady_wind" else 0.5 for e, _, _ in cal]
        flow = (0.0 if HEIGHT in setup.refined else 0.04) if "tanker_wake" in cand else \
            0.005 if "steady_wind" in cand else 0.015
        g = math.hypot(floor, flow)
        return Candidate("+".join(cand), list(cand), len(cal), params=effects_at(cand, x, setup.refined),
                         param_stderr=effects_at(cand, [0.01] * len(cal), setup.refined), gap_after_heldout=g,
                         gap_after_train=g, folds=[{"held_out": "L1", "params": x, "gap_train": g, "gap_heldout": g}])
    sel = SEL.forward_select(["L1"], ["tanker_wake", "steady_wind"], Setup(),
                             lambda fn, js, progress=None: [fn(j) for j in js], math.hypot(floor, 0.015), floor,
                             score=score, refinable=(HEIGHT,))
    step1 = sel.steps[0]
    assert step1["candidate"] == "tanker_wake" and not step1["accepted"]
    assert any("vertical_offset_m" in c.params.get("tanker_wake", {}) for c in sel.fitted)
    assert sel.chosen is None and sel.refined == () and sel.to_json()["refined"] == []
