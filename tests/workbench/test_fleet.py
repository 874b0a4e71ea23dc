"""Fleet calibrations (`workbench.diagnosis.fleet`): which effects belong to the
hardware, the file's round trip and its refusals, the prior under every
simulation of a setup, tolerances about the fleet's values, and the committed
file agreeing with the committed diagnosis it was derived from."""
from __future__ import annotations

import json
import types
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import given, settings, strategies as st
from numpy.testing import assert_allclose

from solver.effects import EFFECTS
from workbench.diagnosis import evaluate as E
from workbench.diagnosis import fleet
from workbench.diagnosis.explanation import calibration, explain
from workbench.diagnosis.setup import Setup, freeze
from workbench.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
FLIGHT = ROOT / "flighttest" / "logs" / "flight"


def test_the_hardware_s_effects_are_its_factors_model_form_and_the_tanker_wake():
    assert {e for e in EFFECTS if fleet.of_hardware(e)} == {
        "drogue_lift", "drogue_drag", "hose_drag", "hose_stiffness", "tanker_wake", "drogue_reference"}


def _family(selected: dict, ranking_first: dict | None = None):
    """A stand-in `FamilyDiagnosis`: the selected set fitted at `selected`, and
    another candidate ranked first (turbulence joined, say) when given."""
    chosen = types.SimpleNamespace(effects=list(selected), params=selected)
    ranking = [chosen] if ranking_first is None else [types.SimpleNamespace(effects=list(ranking_first),
                                                                            params=ranking_first), chosen]
    return types.SimpleNamespace(ranking=ranking, selection={"effects": list(selected)}, logs=["L1", "L2"],
                                 reel_established=None)


def test_an_entry_keeps_the_selected_set_s_hardware_effects_not_the_day_s():
    selected = {"drogue_lift": {"scale": 0.65}, "steady_wind": {"vertical_mps": -6.0, "lateral_mps": 5.3},
                "drogue_reference": {"offset_m": -0.21}}
    fam = _family(selected, ranking_first={"turbulence": {"sigma_mps": 1.0, "length_scale_m": 533.4}})
    # a steady wind two flights share is the pod's flow angle; the turbulence ranked first is the day's
    e = fleet.entry(fam)
    assert e == {"effects": selected, "logs": ["L1", "L2"]}
    # ... one flight's wind is its weather
    fam.logs = ["L1"]
    assert fleet.entry(fam) == {"effects": {"drogue_lift": {"scale": 0.65}, "drogue_reference": {"offset_m": -0.21}},
                                "logs": ["L1"]}
    assert fleet.of_hardware("steady_wind", 2) and not fleet.of_hardware("turbulence", 4)
    assert fleet.entry(types.SimpleNamespace(ranking=[], selection={"effects": []}, logs=[])) is None


VALUES = st.floats(0.01, 3.0, allow_nan=False)


@settings(max_examples=40, deadline=None)
@given(lift=VALUES, drag=st.floats(0.2, 3.0), wake=st.floats(0.0, 3.0), offset=st.floats(-0.6, 0.6))
def test_the_fleet_file_reads_back_what_was_written(tmp_path_factory, lift, drag, wake, offset):
    fams = {"engagement/kdc10/kdc10_pod": _family({"drogue_lift": {"scale": lift}, "tanker_wake": {"strength": wake},
                                                   "drogue_reference": {"offset_m": offset}}),
            'odd "name"/x': _family({"drogue_drag": {"scale": drag}})}
    path = tmp_path_factory.mktemp("fleet") / "fleet.toml"
    path.write_text(fleet.text(types.SimpleNamespace(families=fams), 'made by "a test"'))
    got = fleet.load(path)
    assert got == {"engagement/kdc10/kdc10_pod": {"drogue_lift": {"scale": lift}, "tanker_wake": {"strength": wake},
                                                  "drogue_reference": {"offset_m": offset}},
                   'odd "name"/x': {"drogue_drag": {"scale": drag}}}


REEL = {"reel": "kdc10_pod", "delay_s": 0.2, "natural_frequency_rad_s": 4.05, "damping_ratio": 0.396,
        "gain": 0.935, "everyday_misfit_m": 0.09, "logs": ["EN-KDC10-E11", "EN-KDC10-E7"]}


def test_the_fleet_file_reads_back_a_reel_s_reference_response(tmp_path):
    fam = _family({"drogue_lift": {"scale": 0.6}})
    fam.reel_established = REEL
    path = tmp_path / "fleet.toml"
    path.write_text(fleet.text(types.SimpleNamespace(families={"engagement/kdc10/kdc10_pod": fam}), "a test"))
    assert fleet.reel_references(path) == {"kdc10_pod": {k: v for k, v in REEL.items() if k != "reel"}}
    assert fleet.load(path) == {"engagement/kdc10/kdc10_pod": {"drogue_lift": {"scale": 0.6}}}
    assert fleet.reel_references(tmp_path / "none.toml") == {}


@pytest.mark.parametrize("key,value", [("gain", None), ("damping_ratio", 0.0), ("everyday_misfit_m", -0.1),
                                       ("delay_s", float("nan"))])
def test_a_bad_reel_reference_is_bad_input_naming_the_key(tmp_path, key, value):
    ref = {k: v for k, v in REEL.items() if k not in ("reel", "logs", key)}
    body = "[reels.kdc10_pod]\n" + "".join(f"{k} = {v!r}\n" for k, v in ref.items())
    if value is not None:
        body += f"{key} = {'nan' if value != value else repr(value)}\n"
    path = tmp_path / "fleet.toml"
    path.write_text(body)
    with pytest.raises(InputError, match=f"reels.kdc10_pod.{key}"):
        fleet.reel_references(path)


@pytest.mark.parametrize("body,says", [
    ('[families."a"]\nsteady_wind = { vertical_mps = 1.0 }', "not an effect of the hardware"),
    ('[families."a"]\nno_such = { scale = 1.0 }', "not an effect of the hardware"),
    ('[families."a"]\ndrogue_lift = { gain = 1.0 }', "no such parameter"),
    ('[families."a"]\ndrogue_lift = { scale = -1.0 }', "outside"),
    ('[families."a"\n', "not a TOML file")])
def test_a_bad_fleet_file_is_bad_input_naming_the_key(tmp_path, body, says):
    path = tmp_path / "fleet.toml"
    path.write_text(body)
    with pytest.raises(InputError, match=says):
        fleet.load(path)
    assert fleet.load(tmp_path / "none.toml") == {}


def test_every_simulation_of_a_setup_carries_its_prior_under_the_candidate(monkeypatch):
    seen = []
    monkeypatch.setattr(E, "observed", lambda path: "obs")
    monkeypatch.setattr(E, "_simulate_frozen", lambda path, frozen, setup: seen.append(dict(frozen)) or "sim")
    monkeypatch.setattr(E, "residual", lambda ob, sim, delay_s, tracker_offset_m, signatures:
                        seen.append(tracker_offset_m) or "R")
    prior = {"drogue_lift": {"scale": 0.033}, "tanker_wake": {"strength": 0.9}, "drogue_reference": {"offset_m": -0.2}}
    setup = Setup(prior=freeze(prior))
    assert setup.prior_effects == prior and setup.off("drogue_lift", "scale") == 0.033
    assert setup.off("drogue_drag", "scale") == EFFECTS["drogue_drag"].params["scale"].off
    E.unweighted("log", {"drogue_lift": {"scale": 0.5}}, setup)
    # the candidate's lift replaces the prior's; the wake stays; the tracked point's
    # offset (comparison only) reaches the comparison, not the physics
    frozen, offset = seen
    assert {k: dict(v) for k, v in frozen.items()} == {"drogue_lift": {"scale": 0.5}, "tanker_wake": {"strength": 0.9}}
    assert offset == -0.2
    seen.clear()
    E.unweighted("log", {}, Setup())
    assert seen == [{}, 0.0]


def test_a_refit_within_the_data_sheet_s_tolerance_of_the_fleet_s_value_is_a_calibration():
    tol = EFFECTS["drogue_lift"].params["scale"].tolerance
    ref = {"scale": 0.033}
    assert calibration("drogue_lift", {"scale": 0.033 * (1 + 0.9 * tol)}, ref)
    assert "fleet's 0.033" in calibration("drogue_lift", {"scale": 0.033 * (1 - 0.9 * tol)}, ref)
    assert calibration("drogue_lift", {"scale": 0.033 * (1 + 1.1 * tol)}, ref) is None
    # the data sheet's value is far from what this hardware flies: an event about the fleet
    assert calibration("drogue_lift", {"scale": 1.0}, ref) is None
    named, cals = explain(["drogue_lift", "hose_drag"], {"drogue_lift": {"scale": 0.034}, "hose_drag":
                                                         {"crossflow": 2.0}}, {"drogue_lift": ref})
    assert named == ["hose_drag"] and list(cals) == ["drogue_lift"]


def test_update_committed_derives_the_fleet_from_the_data_sheets_only():
    from workbench.cli.main import cli
    r = CliRunner().invoke(cli, ["diagnose", str(FLIGHT / "TR-KDC10-E7.mcap"), "--update-committed"])
    assert r.exit_code == 2 and "--baseline datasheet" in r.output


def test_the_committed_fleet_is_the_committed_diagnosis_s_hardware():
    js = json.loads((ROOT / "reports" / "diagnose" / "diagnosis.json").read_text())
    assert js["baseline"] == "datasheet"
    got = fleet.load()
    for name, fam in js["families"].items():
        chosen = fam["selection"]["effects"]
        top = next(c for c in fam["ranking"] if c["effects"] == chosen)
        params = top["params"] if len(chosen) > 1 else {chosen[0]: top["params"]}
        want = {e: params[e] for e in chosen if fleet.of_hardware(e, len(fam["logs"]))}
        assert set(got.get(name, {})) == set(want), name
        for e, ps in want.items():
            for k, v in ps.items():
                assert_allclose(got[name][e][k], v, rtol=1e-12)


def test_the_committed_reel_reference_is_the_committed_diagnosis_s():
    js = json.loads((ROOT / "reports" / "diagnose" / "diagnosis.json").read_text())
    est = [f["reel_established"] for f in js["families"].values() if f.get("reel_established")]
    assert est, "the committed diagnosis of the program's engagements establishes its reel's response"
    got = fleet.reel_references()
    for e in est:
        assert got[e["reel"]] == {k: v for k, v in e.items() if k != "reel"}


def test_a_log_of_a_listed_family_is_diagnosed_against_its_fleet_calibration(monkeypatch):
    from workbench.diagnosis import rank as RK
    seen = {}

    def capture(paths, setup, mapper, progress):
        seen[tuple(paths)] = setup.prior_effects
        return types.SimpleNamespace(ranking=[], baseline=setup.prior_effects)
    monkeypatch.setattr(RK, "diagnose_family", capture)
    monkeypatch.setattr(RK, "findings", lambda d: [])
    log = str(FLIGHT / "PD-G3-1.mcap")
    out = RK.diagnose([log], workers=1)
    assert seen[(log,)] == fleet.load()["pitch_doublet/g3/fa18_buddy"] and out.baseline == "fleet"
    out = RK.diagnose([log], workers=1, baseline="datasheet")
    assert seen[(log,)] == {} and out.baseline == "datasheet"
    with pytest.raises(ValueError, match="baseline"):
        RK.diagnose([log], workers=1, baseline="tunnel")
