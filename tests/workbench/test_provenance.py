"""Provenance of stored results: one JSON-safe converter, file and source hashes."""
import hashlib
import json
import math

import numpy as np

import solver
import workbench.provenance as prov
from workbench.provenance import dependency_versions, file_sha256, json_safe, source_sha256


def test_json_safe_makes_strict_json_of_numpy_and_non_finite_values():
    v = {"a": np.float64(1.5), 2: [np.int64(3), (np.bool_(True), math.nan)],
         "arr": np.array([[1.0, np.inf], [0.5, -2.0]]), "n": None, "s": "x"}
    out = json_safe(v)
    assert out == {"a": 1.5, "2": [3, [True, None]], "arr": [[1.0, None], [0.5, -2.0]], "n": None, "s": "x"}
    assert type(out["a"]) is float and type(out["2"][0]) is int and type(out["2"][1][0]) is bool
    json.dumps(out, allow_nan=False)


def test_source_hashes_name_files_by_repository_path(tmp_path):
    p = tmp_path / "f.bin"
    p.write_bytes(b"abc")
    assert file_sha256(p) == hashlib.sha256(b"abc").hexdigest()
    one = source_sha256([prov])
    assert one == {"workbench/provenance.py": file_sha256(prov.__file__)}
    # a package: every module in it
    pkg = source_sha256([solver])
    assert "solver/__init__.py" in pkg and "solver/model.py" in pkg


def test_dependency_versions_are_the_installed_ones():
    v = dependency_versions(("numpy", "no-such-distribution-xyz"))
    assert v == {"numpy": np.__version__, "no-such-distribution-xyz": None}


def test_the_code_version_is_the_tree_the_command_started_on(monkeypatch):
    # a verb's own writes (diagnose --update-committed rewrites tracked result
    # files before the fleet file records the code) must not mark its code dirty
    from click.testing import CliRunner
    from workbench.cli.main import cli
    answers = iter(["f8e5b93", "f8e5b93-dirty"])
    monkeypatch.setattr(prov.subprocess, "run", lambda *a, **k: type("R", (), {"stdout": next(answers)})())
    prov.code_version.cache_clear()
    try:
        # the group takes it before the verb runs (here the verb only prints its help)
        assert CliRunner().invoke(cli, ["logs", "--help"]).exit_code == 0
        assert prov.code_version.cache_info().currsize == 1
        assert prov.code_version() == "f8e5b93"      # asked again after a write: the start's answer
    finally:
        prov.code_version.cache_clear()
