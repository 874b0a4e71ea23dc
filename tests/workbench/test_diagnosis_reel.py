"""The reel lag from the reel channel (`workbench.diagnosis.reel`): the evidence
on the program's engagements and on one whose reel is late, its step in the
selection, and its share of the probability beside turbulence."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest
from numpy.testing import assert_allclose

from flighttest import make_record, read_record
from workbench.diagnosis import select as SEL
from workbench.diagnosis.rank import probabilities, rank_selection
from workbench.diagnosis.reel import EFFECT, established, reel_evidence, reel_tracks, with_reel
from workbench.diagnosis.result import Candidate
from workbench.diagnosis.setup import NOISE_FACTOR

from tests.workbench.test_select import _est, _none, _select, _turb

FLIGHT = Path(__file__).resolve().parents[2] / "flighttest" / "logs" / "flight"
E7, E11 = str(FLIGHT / "EN-KDC10-E7.mcap"), str(FLIGHT / "EN-KDC10-E11.mcap")


@pytest.fixture(scope="module")
def logs():
    return {E7: read_record(E7), E11: read_record(E11)}


def _late(rec, delay_s):
    """`rec` with its payout `delay_s` later: a reel that takes the hose up late."""
    payout = rec.topic("/reel/hose_out").copy()
    payout.index = payout.index + delay_s
    return make_record(rec.info.raw, {**rec.topics, "/reel/hose_out": payout}, rec.start_time_ns)


def test_one_program_engagement_held_to_the_others_reel_is_no_event(logs):
    ref = established(reel_tracks([E11], logs), "kdc10_pod")
    ev = reel_evidence(reel_tracks([E7], logs), "kdc10_pod", ref)
    # engagement 7 under engagement 11's response: 0.090 m against 11's own 0.082 m
    assert not ev.event and ev.ratio == pytest.approx(1.11, abs=0.01) and ev.presence < 0.05
    both = established(reel_tracks([E7, E11], logs), "kdc10_pod")
    assert both["logs"] == ["EN-KDC10-E11", "EN-KDC10-E7"] and both["everyday_misfit_m"] == pytest.approx(0.090,
                                                                                                          abs=0.001)


def test_a_reel_late_by_twice_its_everyday_misfit_is_an_event_with_its_probability(logs):
    ref = established(reel_tracks([E11], logs), "kdc10_pod")
    # measured: 0.2 s later, 1.76 x the everyday misfit (not an event); 0.4 s, 2.91 x; 0.6 s, 4.10 x
    ratios = []
    for delay in (0.2, 0.4, 0.6):
        ev = reel_evidence(reel_tracks(["late"], {"late": _late(logs[E7], delay)}), "kdc10_pod", ref)
        ratios.append(ev.ratio)
        z = math.sqrt(ev.n_pieces) * math.log(ev.ratio / NOISE_FACTOR)
        assert_allclose(ev.presence, 0.5 * math.erfc(-z / math.sqrt(2)), rtol=1e-12)
        assert ev.event == (ev.ratio > NOISE_FACTOR) == (ev.presence > 0.5)
        assert ev.to_json()["event"] == ev.event and "everyday misfit" in ev.why()
    assert ratios == sorted(ratios) and ratios[0] < NOISE_FACTOR < ratios[1]
    # the track's length (contact 10.44 s to disconnect 30.81 s, 2 s either side) over the
    # reference response's period
    period = 2 * math.pi / ref["natural_frequency_rad_s"]
    assert ev.n_pieces == pytest.approx((30.81 - 10.44 + 4.0) / period, rel=0.01)


def _evidence(ratio):
    return type("E", (), {"event": ratio > NOISE_FACTOR, "presence": 0.9 if ratio > NOISE_FACTOR else 0.1,
                          "why": lambda self: f"ratio {ratio}"})()


def test_the_reel_lag_joins_the_selected_set_from_its_own_evidence_with_no_share_of_the_gap():
    sel, g0 = _select({"drogue_lift": 1.0}, floor=0.01, remainder=0.3)
    none = _none(g0)
    out = with_reel(sel, none, _evidence(3.0))
    assert out.chosen.effects == sel.chosen.effects + [EFFECT] and out.steps[-1]["accepted"]
    assert out.chosen.gap_after_heldout == sel.chosen.gap_after_heldout and out.chosen.shares[EFFECT] == 0.0
    assert out.chosen.n_params == sel.chosen.n_params + 1 and "reel channel" in out.stopped
    alone = next(c for c in out.fitted if c.effects == [EFFECT])
    assert alone.gap_after_heldout == g0
    refused = with_reel(sel, none, _evidence(1.5))
    assert refused.chosen is sel.chosen and not refused.steps[-1]["accepted"]
    # the step's reason is the reel channel's, and an accepted step has none
    assert refused.steps[-1]["why"] == "ratio 1.5" and out.steps[-1]["why"] is None
    assert all("refused" in c.why_not_first for c in refused.fitted if EFFECT in c.effects)


def test_turbulence_and_the_reel_lag_share_their_set_s_weight_as_independent_events():
    from workbench.diagnosis.turbulence import _joined
    sel, g0 = _select({"tanker_wake": 1.0}, floor=0.01, remainder=0.3)
    base = sel.chosen
    joint = _joined(base, _turb(["turbulence"], 0.05))
    sel = SEL.with_random(sel, _turb(["turbulence"], 0.3 * g0), joint, g0, _est(1.0, 0.1))
    assert sel.chosen is joint
    none = _none(g0)
    sel = with_reel(sel, none, _evidence(3.0))
    p_t, p_r = 0.8, 0.9
    ranking = rank_selection(sel, none, 0.01, n_heldout=200, presence={"turbulence": p_t, EFFECT: p_r})
    assert ranking[0].effects == base.effects + ["turbulence", EFFECT]
    det = [c for c in ranking if not {"turbulence", EFFECT} & set(c.effects)]
    w = dict(zip((c.effect for c in det), probabilities([c.gap_after_heldout for c in det],
                                                         [c.n_params for c in det], 0.01, 200)))
    by = {tuple(c.effects): c.probability for c in ranking}
    wake = tuple(base.effects)
    # every combination of the two on the selected set, the product of their probabilities
    assert_allclose(by[wake + ("turbulence", EFFECT)], w[base.effect] * p_t * p_r, rtol=1e-12)
    assert_allclose(by[wake + (EFFECT,)], w[base.effect] * (1 - p_t) * p_r, rtol=1e-12)
    assert_allclose(by[wake + ("turbulence",)], w[base.effect] * p_t * (1 - p_r), rtol=1e-12)
    assert_allclose(by[wake], w[base.effect] * (1 - p_t) * (1 - p_r), rtol=1e-12)
    # so on "none": turbulence alone, the reel lag alone, both, neither
    assert_allclose(by[("turbulence", EFFECT)], w["none"] * p_t * p_r, rtol=1e-12)
    assert_allclose(by[(EFFECT,)], w["none"] * (1 - p_t) * p_r, rtol=1e-12)
    assert_allclose(sum(c.probability for c in ranking), 1.0, rtol=1e-12)


def test_the_reel_lag_alone_stays_ahead_of_none_beside_real_everyday_air():
    # the everyday air moves what it could have done by chance behind "none"; the reel lag,
    # measured on its own channel, explains none of the gap and is not moved with it
    from workbench.diagnosis.turbulence import RandomEffect
    turb = Candidate("turbulence", ["turbulence"], 1, gap_before=0.10, gap_after_heldout=0.09, score=0.095)
    none = Candidate("none", [], 0, gap_before=0.10, gap_after_heldout=0.10, score=0.10)
    alone = dataclasses.replace(none, effect=EFFECT, effects=[EFFECT], n_params=1)
    real = _est(0.6, 0.1)
    ranked = RandomEffect(turb, real, 0.04).credit_steady([alone, turb, none], accepted=False)
    assert ranked == [alone, none, turb]


def test_findings_of_a_family_with_the_reel_lag_alone_ranked_say_what_the_reel_channel_showed():
    from workbench.diagnosis.findings import findings
    from workbench.diagnosis.result import FamilyDiagnosis
    folds = [{"held_out": log, "params": [0.6], "gap_train": 0.05, "gap_heldout": 0.06} for log in ("E7", "E11")]
    top = Candidate("drogue_lift", ["drogue_lift"], 1, params={"drogue_lift": {"scale": 0.6}},
                    param_stderr={"drogue_lift": {"scale": 0.01}}, gap_before=0.3, gap_after_heldout=0.06,
                    shrink_heldout=0.8, probability=0.7, folds=folds)
    none = Candidate("none", [], 0, gap_before=0.3, gap_after_heldout=0.3, probability=0.0)
    alone = dataclasses.replace(none, effect=EFFECT, effects=[EFFECT], n_params=1)   # folds: none's, None
    ev = {"why": "the take-up misses reel kdc10_pod's reference response by 0.089 m RMS", "probability": 0.02}
    d = FamilyDiagnosis(family="engagement/kdc10/kdc10_pod", kind="engagement", logs=["E7", "E11"],
                        n_elements=40, gap_definition="", gap_before=0.3, noise_floor=0.01, gap_real=True,
                        held_out_scheme="", screen={}, not_applicable={}, ranking=[top, none, alone], failed=[],
                        remaining_unexplained={"gap_m": 0.06, "above_noise_m": 0.059}, gap={}, gap_after_best={},
                        wall_s=1.0, reel=ev)
    text = "\n".join(findings(d))
    assert "drogue_lift fitted without each log in turn" in text
    assert "Reel lag, from the reel channel: the take-up misses" in text and "0.02" in text


def test_with_the_turbulence_refused_every_combination_on_the_set_is_ranked():
    from workbench.diagnosis.turbulence import _joined
    sel, g0 = _select({"tanker_wake": 1.0}, floor=0.01, remainder=0.3)
    base = sel.chosen
    sel = SEL.with_random(sel, _turb(["turbulence"], 0.3 * g0), _joined(base, _turb(["turbulence"], 0.05)), g0,
                          _est(0.3, 0.1))
    assert sel.chosen is base                                     # calmer than light: refused
    none = _none(g0)
    ranking = rank_selection(with_reel(sel, none, _evidence(1.5)), none, 0.01, n_heldout=200,
                             presence={"turbulence": 0.2, EFFECT: 0.1})
    on_set = {tuple(e for e in c.effects if e not in base.effects) for c in ranking
              if [e for e in c.effects if e not in ("turbulence", EFFECT)] == base.effects}
    assert on_set == {(), ("turbulence",), (EFFECT,), ("turbulence", EFFECT)}
    assert_allclose(sum(c.probability for c in ranking), 1.0, rtol=1e-12)


def test_the_program_s_engagements_bear_out_no_reel_event_against_their_own_reel():
    import json
    js = json.loads((FLIGHT.parents[2] / "reports" / "diagnose" / "diagnosis.json").read_text())
    fam = js["families"]["engagement/kdc10/kdc10_pod"]
    # measured on the committed run: 0.94 x the everyday misfit
    assert not fam["reel"]["event"] and fam["reel"]["ratio"] < 1.0 and fam["reel"]["probability"] < 1e-3
    effects = [c["effects"] for c in fam["ranking"]]
    assert effects.index([EFFECT]) == effects.index([]) + 1 and fam["selection"]["effects"][-1] != EFFECT


def test_two_fits_of_one_form_keep_their_own_weights_beside_the_measured_variants():
    # a set fitted twice (a step's refit) ranks twice: each keeps its own weight, and the
    # measured variants split only the one they stand on, so the whole still sums to 1
    from workbench.diagnosis.rank import with_random_share
    a = Candidate("drogue_lift", ["drogue_lift"], 1, params={"drogue_lift": {"scale": 0.6}})
    b = dataclasses.replace(a)
    none = Candidate("none", [], 0)
    ra = dataclasses.replace(b, effect="drogue_lift+reel_lag", effects=["drogue_lift", EFFECT],
                             params={**b.params, EFFECT: {}})
    ranking = [a, b, ra, none]
    with_random_share(ranking, {id(a): 0.5, id(b): 0.3, id(none): 0.2}, {EFFECT: 0.25})
    assert_allclose([c.probability for c in ranking], [0.5, 0.3 * 0.75, 0.3 * 0.25, 0.2], rtol=1e-12)
