"""The one mapper (local processes or Dask), the defaults in one place, and
the one simulate path."""
from __future__ import annotations

import dataclasses
import json

import pytest
from click.testing import CliRunner
from numpy.testing import assert_allclose

from tests.workbench.test_cli import DEMO, TRAIL
from workbench import config
from workbench.cases import load_case
from workbench.cli import cli
from workbench.parallel import Mapper
from workbench.simulate import run_duration, simulate_case


def _square(x):
    return x * x


def test_mapper_keeps_job_order_locally_and_in_series():
    jobs = list(range(7))
    seen = []
    assert Mapper(workers=2)(_square, jobs) == [j * j for j in jobs]
    assert Mapper(workers=1)(_square, jobs, progress=seen.append) == [j * j for j in jobs]
    assert seen == [j * j for j in jobs]


def test_mapper_refuses_fewer_than_one_worker():
    with pytest.raises(ValueError, match="workers must be at least 1"):
        Mapper(workers=0)


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    # threads in this process: the workers import this checkout, not an installed copy
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as c:
        yield c


def test_mapper_on_a_dask_cluster(cluster):
    with Mapper(scheduler=cluster.scheduler_address) as m:
        assert m(_square, [3, 1, 2]) == [9, 1, 4]
    assert "square" in cluster.scheduler.task_prefixes   # it ran there (dask drops the underscore)


def test_validate_runs_a_campaign_on_a_dask_cluster(cluster, tmp_path):
    case = tmp_path / "case.toml"
    case.write_text(TRAIL)
    outs = {}
    for name, extra in (("local", ["--workers", "1"]), ("dask", ["--scheduler", cluster.scheduler_address])):
        out = tmp_path / name
        res = CliRunner().invoke(cli, ["validate", str(case), "--out", str(out), "--no-progress", *extra])
        assert res.exit_code == 0, res.output
        outs[name] = json.loads((out / "results.json").read_text())["cases"][0]["metrics"]
    # the runs went to the cluster, and came back the same: same model, same solver, same numbers
    assert "guarded_run" in cluster.scheduler.task_prefixes   # dask drops the leading underscore
    assert outs["dask"] == outs["local"]


def test_defaults_set_and_reset():
    with pytest.raises(KeyError, match="simulate.durations_s"):
        config.set_defaults("simulate", durations_s=3.0)
    case = load_case(DEMO)
    tables = dict(case.tables)
    tables["run"] = dict(tables["run"], duration_s=None)
    case = dataclasses.replace(case, tables=tables)
    try:
        config.set_defaults("simulate", duration_s=3.0)
        assert run_duration(case) == 3.0
    finally:
        config.reset_defaults()
    assert run_duration(case) == 10.0


def test_simulate_case_static_only_and_model_left_as_built():
    case = load_case(DEMO)
    static = simulate_case(case, duration=0.0)
    assert static.result is None and static.run_s == 0.0
    run = simulate_case(case, duration=0.2)
    # the static trail is the run's first sample: one model, one static solve
    assert_allclose(run.result.end_xyz[0], static.static.pos[-1], rtol=0, atol=1e-12)
    assert run.model.end is None and run.options.n_elements == run.model.n_elements
    # the run spans what was asked, to the sample step
    assert_allclose(run.result.t[-1] - run.result.t[0], 0.2, atol=float(case["run"]["record_dt_s"]))


def test_an_unreachable_scheduler_is_bad_input(tmp_path):
    pytest.importorskip("distributed")
    import dask
    case = tmp_path / "case.toml"
    case.write_text(TRAIL)
    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        res = CliRunner().invoke(cli, ["validate", str(case), "--out", str(tmp_path / "out"), "--no-progress",
                                       "--scheduler", "tcp://127.0.0.1:1"])
    assert res.exit_code == 2, res.output
    assert "--scheduler tcp://127.0.0.1:1: cannot reach the Dask scheduler" in res.output


@pytest.mark.slow
def test_the_proving_ground_runs_its_logs_on_a_dask_cluster(cluster, tmp_path):
    """`diagnose --selftest --scheduler` (issue 13, item 7): the proving ground's
    logs generated and diagnosed on the cluster give the rows local processes
    give (same seed, same logs, same diagnosis)."""
    rows = {}
    for name, extra in (("local", ["--workers", "1"]), ("dask", ["--scheduler", cluster.scheduler_address])):
        out = tmp_path / name
        res = CliRunner().invoke(cli, ["diagnose", "--selftest", "--proving-ground", "independent", "--n", "1",
                                       "--seed", "5", "--out", str(out), "--no-progress", *extra])
        assert res.exit_code == 0, res.output
        rows[name] = json.loads((out / "proving-single.json").read_text())["rows"]
    keys = ("kind", "truth", "top", "gap_before", "gap_after_heldout")

    def kept(r):
        return {**{k: r[k] for k in keys}, "ranking": [c["effect"] for c in r["candidates"]]}
    assert [kept(r) for r in rows["dask"]] == [kept(r) for r in rows["local"]]
    assert "run_one" in cluster.scheduler.task_prefixes   # it ran there
