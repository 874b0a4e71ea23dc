"""The diagnosis proven on generated logs whose effect it is not told (a small
version of `workbench diagnose --selftest`), the where-map and JSON contract of
a real-log-like run, the Dask scheduler path, the folds, and a failed candidate
kept out of the ranking."""
import json
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import pytest

from solver.effects import EFFECTS
from solver.chain import DivergenceError
from workbench import diagnosis as D
from workbench.diagnosis import evaluate as E
from workbench.diagnosis import rank as RK
from workbench.diagnosis import selftest as S
from workbench.diagnosis.findings import findings
from workbench.diagnosis.screen import screen_scores
from workbench.parallel import Mapper

FLIGHT = Path(__file__).resolve().parents[2] / "flighttest" / "logs" / "flight"

# two kinds, two effects each, chosen before the diagnosis runs; engagements are
# covered by the full `--selftest` (one engagement diagnosis alone takes ~1 min)
PLAN = [("pitch_doublet", "drogue_lift", 11), ("pitch_doublet", "sensor_lag", 12),
        ("trail", "tanker_wake", 13), ("trail", "hose_drag", 14)]


@pytest.fixture(scope="module")
def selftest_rows(tmp_path_factory):
    d = tmp_path_factory.mktemp("selftest")
    jobs = [(k, e, s, str(d), D.DEFAULT_ELEMENTS) for k, e, s in PLAN]
    with ProcessPoolExecutor(max_workers=2) as pool:
        return list(pool.map(S._one, jobs))


def test_blind_selftest_finds_the_withheld_effect_and_shrinks_the_held_out_gap(selftest_rows):
    # the targets are over the set: right effect first in >= 90 %, the
    # held-out gap shrinking >= 70 % (median); each log's gap must shrink at all
    import numpy as np
    for r in selftest_rows:
        assert r["correct"], f"{r['log']}: {r['effect']} withheld, diagnosis ranked {r['top']} first"
        assert r["shrink_heldout"] > 0.0, f"{r['log']}: held-out gap did not shrink"
    assert np.median([r["shrink_heldout"] for r in selftest_rows]) >= 0.7


def test_calibrated_parameter_recovers_the_withheld_value(selftest_rows):
    for r in selftest_rows:
        if r["effect"] in ("drogue_lift", "tanker_wake"):
            key = next(iter(r["params"]))
            assert r["top_params"][key] == pytest.approx(r["params"][key], abs=0.15)


def test_diagnosis_json_contract_and_dask_scheduler(tmp_path):
    distributed = pytest.importorskip("distributed")
    path, truth = S.generate("trail", "drogue_drag", 21, tmp_path)
    with distributed.LocalCluster(processes=False, n_workers=1, threads_per_worker=2,
                                  dashboard_address=None) as cluster:
        # a generated log's hardware is the data sheets' (its family's fleet calibration is not its truth)
        out = D.diagnose([str(path)], scheduler=cluster.scheduler_address, baseline="datasheet")
    assert not (tmp_path / "out").exists(), "compute wrote files"
    D.write_diagnosis(out, tmp_path / "out")
    js = json.loads((tmp_path / "out" / "diagnosis.json").read_text())
    assert {"logs", "gap", "ranking"} <= set(js)
    top = js["ranking"][0]
    # the withheld effect is the one event named; the tracked point's offset, model
    # form fitted first, may stand beside it (this log's truth has none: a few mm)
    assert top["named"] == ["drogue_drag"] and set(top["effects"]) <= {"drogue_drag", "drogue_reference"}
    if "drogue_reference" in top["effects"]:
        assert abs(top["params"]["drogue_reference"]["offset_m"]) < 0.05
    assert top["gap_after_heldout"] < 0.3 * top["gap_before"]
    # held-out evidence as probabilities over every ranked candidate, "none" included
    assert sum(c["probability"] for c in js["ranking"]) == pytest.approx(1.0, abs=1e-12)
    # the likeliest on the held-out evidence is first, or the findings say why not
    # (forward selection's acceptance rule, or plausibility, ranks it behind)
    likeliest = max(js["ranking"], key=lambda c: c["probability"])
    assert likeliest is top or any(f"{likeliest['effect']} carries the largest probability" in f
                                   for f in js["findings"])
    w = js["gap"][path.stem]
    assert {"by_channel", "by_station", "by_phase", "by_band"} <= set(w)
    assert w["real"] and w["gap_m"] > w["noise_floor_m"]
    # what is left once the best explanation is in: a smaller gap, and said so
    (fam,) = js["families"].values()
    assert fam["gap_after_best"][path.stem]["gap_m"] < 0.3 * w["gap_m"]
    assert any(f.startswith(f"{path.stem}: with {top['effect']}") for f in js["findings"])
    assert (tmp_path / "out" / "diagnosis.html").read_text().count("<table>") >= 1
    assert out.scheduler == cluster.scheduler_address
    # the typed result: one parameter shape whatever the number of effects
    one = len(top["effects"]) == 1
    assert out.ranking[0].params == ({"drogue_drag": top["params"]} if one else top["params"])
    frame = out.to_pandas()
    assert frame["effect"].iloc[0] == top["effect"] and "drogue_drag.scale" in frame.columns


def test_folds_split_a_family_as_the_diagnosis_scores_it():
    loo = list(D.LeaveOneLogOut().split(["a/L1.mcap", "a/L2.mcap", "a/L3.mcap"]))
    assert [(f.train, f.test, f.label) for f in loo] == [
        (["a/L2.mcap", "a/L3.mcap"], ["a/L1.mcap"], "L1"), (["a/L1.mcap", "a/L3.mcap"], ["a/L2.mcap"], "L2"),
        (["a/L1.mcap", "a/L2.mcap"], ["a/L3.mcap"], "L3")]
    blocks = list(D.TimeBlocks(2.0).split(["a/L1.mcap"]))
    assert [(f.train, f.test, f.label) for f in blocks] == [
        ([("a/L1.mcap", 0)], [("a/L1.mcap", 1)], "L1 segment B"),
        ([("a/L1.mcap", 1)], [("a/L1.mcap", 0)], "L1 segment A")]


def test_selftest_draws_lie_inside_the_registry_search_ranges():
    import numpy as np
    rng = np.random.default_rng(3)
    for kind, effects in S.KIND_EFFECTS.items():
        for e in effects:
            assert EFFECTS[e].calibrated, (kind, e)
            for _ in range(50):
                for k, v in S.DRAWS[e](rng).items():
                    p = EFFECTS[e].params[k]
                    lo, hi = p.search or (p.lo, p.hi)
                    assert lo <= v <= hi, (e, k, v)


def test_a_diverging_candidate_is_recorded_with_its_reason_and_never_ranked(monkeypatch):
    # drogue_lift explains a trail well (it ranks among the best on every real
    # trail); forced to diverge, it must leave the ranking, not enter it with a
    # stand-in gap, and its reason (time and element) must be reported
    reason = "at t=3.2100 s hose element 7 is stretched beyond its breaking strain"
    real = E._simulate_frozen

    def diverging(path, frozen, setup):
        # away from the screen's probes (0.5, 1.5) only: they pass, every point of the
        # fit's grid fails (a grid point alone that fails is no start, `fit._grid_scores`)
        lift = dict(dict(frozen).get("drogue_lift", ()))
        if lift and lift["scale"] not in (0.5, 1.5):
            raise DivergenceError(reason)
        return real(path, frozen, setup)
    monkeypatch.setattr(E, "_simulate_frozen", diverging)
    path = str(FLIGHT / "TR-KDC10-E7.mcap")
    d = RK.diagnose_family([path], D.Setup(), mapper=Mapper(workers=1))
    assert all("drogue_lift" not in c.effects for c in d.ranking)
    # fitted beside the tracked point, model form fitted first
    (failed,) = [c for c in d.failed if "drogue_lift" in c.effects]
    assert not failed.success and reason in failed.message and "DivergenceError" in failed.message
    assert not d.success and reason in d.message
    assert d.ranking[0].success and d.ranking[0].gap_after_heldout < d.gap_before
    js = d.to_json()
    assert js["failed"] == [failed.to_json()] and "gap_after_heldout" not in js["failed"][0]
    assert any(f"{failed.effect} could not be scored" in f for f in findings(d))
    assert "drogue_lift" in d.screen, "screened, then failed in its fit"


def test_an_effect_whose_screen_probe_diverges_is_reported_and_not_scored(monkeypatch):
    reason = "at t=0.0000 s no static shape: hose element 3 in compression"
    real = E._simulate_frozen

    def diverging(path, frozen, setup):
        if "drogue_lift" in dict(frozen):
            raise DivergenceError(reason)
        return real(path, frozen, setup)
    monkeypatch.setattr(E, "_simulate_frozen", diverging)
    path = str(FLIGHT / "TR-KDC10-E7.mcap")
    base = {path: E.evaluate(path, {}, D.Setup())}
    scores, failed, columns = screen_scores([path], ["drogue_lift", "hose_drag"], D.Setup(), base,
                                            Mapper(workers=1))
    assert set(scores) == {"hose_drag"} and 0.0 < scores["hose_drag"] <= 1.0
    # the sensitivity columns kept for identifiability: one row per residual component
    assert set(columns) == {"hose_drag"} and columns["hose_drag"].shape[0] == len(base[path].r)
    assert set(failed) == {"drogue_lift"} and reason in failed["drogue_lift"]
