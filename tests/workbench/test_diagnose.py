"""The diagnosis proven on generated logs whose effect it is not told (a small
version of `workbench diagnose --selftest`), the where-map and JSON contract of
a real-log-like run, and the Dask scheduler path."""
import json
from concurrent.futures import ProcessPoolExecutor

import pytest

from workbench import diagnose as D
from workbench import selftest as S

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
        out = D.diagnose([str(path)], tmp_path / "out", scheduler=cluster.scheduler_address)
    js = json.loads((tmp_path / "out" / "diagnosis.json").read_text())
    assert {"logs", "gap", "ranking"} <= set(js)
    top = js["ranking"][0]
    assert top["effect"] == "drogue_drag"
    assert top["gap_after_heldout"] < 0.3 * top["gap_before"]
    w = js["gap"][path.stem]
    assert {"by_channel", "by_station", "by_phase", "by_band"} <= set(w)
    assert w["real"] and w["gap_m"] > w["noise_floor_m"]
    # what is left once the best explanation is in: a smaller gap, and said so
    (fam,) = js["families"].values()
    assert fam["gap_after_best"][path.stem]["gap_m"] < 0.3 * w["gap_m"]
    assert any(f.startswith(f"{path.stem}: with drogue_drag") for f in js["findings"])
    assert (tmp_path / "out" / "diagnosis.html").read_text().count("<table>") >= 1
    assert out["scheduler"] == cluster.scheduler_address
