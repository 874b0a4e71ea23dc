"""Hose property tables: look-up rules, measurement, tuning, the committed data file
and the paper's Fig. 9 verification."""
import math
import os
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from flighttest import make_record, read_record, write_record
from solver.hose import HoseProperties
from solver.model import Model
from solver.properties import PropertyLibrary, PropertyTable
from workbench import hardware
from workbench.report import run_provenance
from workbench.report.content import properties_blocks
from workbench.cli.properties import properties
from workbench.hardware import load_hardware
from workbench.properties import build, store
from workbench.properties.measure import measure_ringdown
from workbench.properties.rig import BenchRig, rig_mode
from workbench.properties.store import DEFAULT_PATH, load_library, read_properties, write_properties
from workbench.properties.tune import axial_spring_guess, derive_hose, tune_bending
from workbench.properties.verify import DAMPING_TOLERANCE, FREQUENCY_TOLERANCE, simulate_ringdown
from workbench.provenance import code_version

ROOT = Path(__file__).resolve().parents[2]
RINGDOWN = ROOT / "flighttest" / "logs" / "ringdown"


@pytest.fixture(scope="module")
def doc():
    return read_properties(DEFAULT_PATH)


@pytest.fixture(scope="module")
def hw():
    return load_hardware()


def small_table(hose="h", temps=(-40.0, 0.0, 40.0, 60.0), lengths=(0.05, 0.1, 0.2)):
    """k ~ 1/l exactly, a smooth temperature trend."""
    T = np.asarray(temps)[:, None]
    L = np.asarray(lengths)[None, :]
    trend = np.exp(-0.01 * T)
    return PropertyTable(hose, np.asarray(temps), np.asarray(lengths),
                         1e6 * trend / L, 500 * trend / L, 100 * trend / L, 0.7 * trend / L)


# ---- PropertyTable -------------------------------------------------------------------

def test_temperature_outside_tested_range_is_an_error_unless_allowed():
    t = small_table()
    with pytest.raises(ValueError, match=r"temperature 70\.0 F is outside the tested range -40\.0\.\.60\.0 F"):
        t.constants(70.0, 0.1)
    with pytest.raises(ValueError, match="outside the tested range"):
        t.element_constants(-41.0)
    ka, ca, kb, cb = t.constants(70.0, 0.1, allow_extrapolation=True)
    assert kb == pytest.approx(100 * math.exp(-0.7) / 0.1, rel=0.02)


def test_table_reproduces_its_nodes_and_interpolates_one_over_length_exactly():
    t = small_table()
    for i, T in enumerate(t.temperatures_F):
        for j, l in enumerate(t.element_lengths):
            assert t.constants(T, l) == pytest.approx((t.k_a[i, j], t.c_a[i, j], t.k_b[i, j], t.c_b[i, j]),
                                                      rel=1e-12)
    # log-log interpolation is exact for a power law; beyond the ends k l is held
    for l in (0.03, 0.07, 0.13, 0.5):
        kb = t.constants(0.0, l)[2]
        assert kb * l == pytest.approx(100.0, rel=1e-12)
    f = t.element_constants(40.0)
    assert f(0.07) == pytest.approx(t.constants(40.0, 0.07), rel=1e-14)


def test_table_round_trips_and_refuses_bad_arrays():
    t = small_table()
    u = PropertyTable.from_dict(t.to_dict())
    assert u.constants(13.0, 0.08) == pytest.approx(t.constants(13.0, 0.08), rel=1e-14)
    with pytest.raises(ValueError, match="k_b has shape"):
        PropertyTable("h", t.temperatures_F, t.element_lengths, t.k_a, t.c_a, t.k_b[:, :2], t.c_b)
    with pytest.raises(ValueError, match="must be positive"):
        PropertyTable("h", t.temperatures_F, t.element_lengths, t.k_a, t.c_a, -t.k_b, t.c_b)
    lib = PropertyLibrary([t])
    with pytest.raises(ValueError, match=r"no property table for hose 'x' \(tables: h\)"):
        lib.constants("x", 0.0, 0.1)


def test_derived_hose_scales_by_second_moment_of_area(hw):
    src = small_table("kc130_long")
    a, b = hw.get("hose", "kc130_long"), hw.get("hose", "kdc10_pod")
    t, prov = derive_hose(src, a, b)
    ratio = (b.outer_diameter ** 4 - b.inner_diameter ** 4) / (a.outer_diameter ** 4 - a.inner_diameter ** 4)
    assert prov["status"] == "derived" and prov["derived_from"] == "kc130_long"
    assert prov["scale_factor"] == pytest.approx(ratio, rel=1e-12)
    assert t.hose == "kdc10_pod" and "derived" in t.note
    assert np.allclose(np.array(t.constants(10.0, 0.1)) / np.array(src.constants(10.0, 0.1)), ratio)


# ---- measurement ----------------------------------------------------------------------

def synthetic_ringdown(kind, f, zeta, fs=1000.0, hold=1.5, dur=8.0, noise=0.01, seed=1):
    """A hold, a release spike, a decaying first mode of damped frequency f plus
    a second mode (zeta 0.3, gone within a cycle of the first), sensor noise;
    axial: a rocking motion in antiphase on the two accelerometers."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, hold + dur, 1.0 / fs)
    tau = np.clip(t - hold, 0.0, None)
    w = 2 * np.pi * f
    s = zeta * w / math.sqrt(1 - zeta ** 2)
    y = np.where(t >= hold, 3.0 * np.exp(-s * tau) * np.cos(w * tau)
                 + 4.0 * np.exp(-0.3 * 6.3 * w * tau) * np.sin(6.3 * w * tau), 0.0)
    y[int(hold * fs)] += 12.0
    y += noise * rng.standard_normal(len(t))
    idx = pd.Index(t, name="t_s")
    tt = np.arange(0.0, t[-1], 1.0)
    temps = pd.DataFrame({"t1_F": 20.3 + 0 * tt, "t2_F": 20.9 + 0 * tt}, index=pd.Index(tt, name="t_s"))
    info = {"schema_version": "1", "test_id": "SYN", "test_kind": kind, "hose": "fa18_buddy",
            "temperature_F": "20", "section_length_m": "1.22"}
    if kind == "ringdown_axial":
        rock = 0.8 * np.where(t >= hold, np.sin(2 * np.pi * 1.9 * tau), 0.0)
        info.update(tip_mass_kg="12", accel_lever_m="0.1")
        topics = {"/rig/accel/weight": pd.DataFrame({"a1_mps2": y + rock, "a2_mps2": y - rock}, index=idx)}
    else:
        topics = {"/rig/accel/tip": pd.DataFrame({"a_mps2": y}, index=idx)}
    topics["/rig/temperature"] = temps
    return make_record(info, topics, start_time_ns=0)


@pytest.mark.parametrize("kind,f,zeta", [("ringdown_bending", 1.8, 0.04), ("ringdown_axial", 42.0, 0.055)])
def test_measure_ringdown_recovers_known_frequency_and_damping(kind, f, zeta):
    m = measure_ringdown(synthetic_ringdown(kind, f, zeta, dur=8.0 if f < 10 else 1.0))
    assert m["frequency_hz"] == pytest.approx(f, rel=1e-3)
    assert m["damping_ratio"] == pytest.approx(zeta, rel=0.02)
    # the thermocouples, not the setpoint
    assert m["temperature_F"] == pytest.approx(20.6, abs=1e-9)
    assert m["setpoint_F"] == 20.0
    # the window starts after the release and the fast mode
    assert m["decay_window_s"][0] > m["release_s"]


def test_real_bending_record_uses_the_thermocouples():
    rec = read_record(RINGDOWN / "RD-KC130-B-20F-r1.mcap")
    m = measure_ringdown(rec)
    tc = rec.topic("/rig/temperature")
    assert m["temperature_F"] == pytest.approx(np.concatenate([tc.t1_F, tc.t2_F]).mean())
    assert m["temperature_F"] != 20.0
    assert 1.0 < m["frequency_hz"] < 3.0 and 0.01 < m["damping_ratio"] < 0.2


# ---- tuning -----------------------------------------------------------------------

def test_tuning_hits_the_target_mode(hw):
    rig = BenchRig.from_sheet(hw.get("hose", "fa18_buddy"), 1.22)
    axial = axial_spring_guess(BenchRig.from_sheet(hw.get("hose", "fa18_buddy"), 1.22, True, 12.0),
                                 6, 42.0, 0.055)
    r = tune_bending(rig, 6, 2.1, 0.045, 20.0, axial)
    f, z, st, _ = rig_mode(rig, 6, (*axial, r["k_b"], r["c_b"]), 20.0)
    assert f == pytest.approx(2.1, rel=1e-6) and z == pytest.approx(0.045, rel=1e-6)
    assert st.pos[-1, 2] < -0.01     # it sags


# ---- the committed data file -------------------------------------------------------------

def test_data_file_loads_by_hose_and_feeds_the_solver(doc):
    lib = load_library()
    assert set(lib.hoses) >= {"kc130_long", "fa18_buddy", "kdc10_pod"}
    assert doc["hoses"]["kdc10_pod"]["status"] == "derived"
    assert doc["hoses"]["kc130_long"]["status"] == "measured"
    with pytest.raises(ValueError, match=r"temperature 75\.0 F is outside the tested range"):
        lib.constants("kc130_long", 75.0, 0.2)
    fn = lib.element_constants("kdc10_pod", 2.0)
    hose = HoseProperties(length=22.86, outer_diameter=0.0635, inner_diameter=0.0445,
                          dry_mass_per_length=2.2, EI=1.0, EA=1.0, element_constants=fn)
    m = Model(hose, 40, 0.77, 2.2e-5)
    assert m.nominal_constants() == pytest.approx(lib.constants("kdc10_pod", 2.0, 22.86 / 40))
    # provenance: every record is named with its hash, every number with its method
    files = {r["file"] for r in doc["inputs"]["records"]}
    assert files == {p.name for p in RINGDOWN.glob("*.mcap")}
    assert all(re.fullmatch(r"[0-9a-f]{64}", r["sha256"]) for r in doc["inputs"]["records"])
    assert {"measurement", "tuning", "interpolation", "axial_temperature", "verification"} <= set(doc["method"])


def test_shorter_elements_are_stiffer_and_more_damped(doc):
    for hose, p in doc["hoses"].items():
        t = PropertyTable.from_dict(doc["tables"][hose])
        for name in ("k_a", "c_a", "k_b", "c_b"):
            v = getattr(t, name)
            assert np.all(np.diff(v, axis=1) < 0), (hose, name)   # lengths ascend
            # constant x length tends to the continuum value as the elements shorten:
            # it changes monotonically with length and by a few percent at most
            vl = v * t.element_lengths[None, :]
            assert np.all(np.diff(vl, axis=1) >= 0), (hose, name)
            assert np.all(vl[:, -1] / vl[:, 0] < 1.2), (hose, name)


def test_committed_verification_meets_the_issue_tolerance(doc):
    rows = doc["verification"]
    hoses = {r["hose"] for r in rows if r["test"] == "bending"}
    assert hoses == {"kc130_long", "fa18_buddy"}
    for r in rows:
        assert r["n_elements"] == 8
        assert abs(r["frequency_error_pct"]) <= 0.5 and abs(r["damping_error_pct"]) <= 2.0, r


@pytest.mark.parametrize("hose,which", [("kc130_long", 0), ("fa18_buddy", -1)])
def test_fig9_time_simulation_at_eight_elements(doc, hw, hose, which):
    """Re-run the paper's Fig. 9 check live: the 8-element bench model with
    constants looked up in the committed table, simulated, measured like a record."""
    p = doc["hoses"][hose]
    g = p["bending_groups"][which]
    lib = load_library()
    rig = BenchRig.from_sheet(hw.get("hose", hose), p["bench_rig"]["bending"]["section_length_m"])
    T = g["temperature_F"]["mean"]
    f, z = g["frequency_hz"]["mean"], g["damping_ratio"]["mean"]
    sim = simulate_ringdown(rig, 8, lib.element_constants(hose, T), T, g["amplitude_at_release_m"], f, z)
    m = measure_ringdown(sim)
    assert abs(m["frequency_hz"] / f - 1) <= FREQUENCY_TOLERANCE
    assert abs(m["damping_ratio"] / z - 1) <= DAMPING_TOLERANCE


# ---- end to end on records of known constants ---------------------------------------------

def test_build_recovers_the_constants_that_made_the_records(tmp_path, hw):
    """Records simulated from known constants (16 elements), written in the log
    contract, then `workbench properties build`: the tuned 16-element constants
    must come back."""
    logs = tmp_path / "ringdown"
    logs.mkdir()
    shutil.copy(ROOT / "flighttest" / "logs" / "hardware.toml", tmp_path / "hardware.toml")
    sheet = hw.get("hose", "fa18_buddy")
    rig = BenchRig.from_sheet(sheet, 1.22)
    ax = BenchRig.from_sheet(sheet, 1.22, hanging=True, tip_mass=12.0)
    n = 16
    l = rig.length / n
    EA, eta_a = 1.1e6, 460.0
    truth = {0.0: (150.0, 1.2), 30.0: (110.0, 0.8), 60.0: (80.0, 0.5)}   # EI, eta_b
    for T, (EI, eta) in truth.items():
        c = (EA / l, eta_a / l, EI / l, eta / l)
        f, z, _, _ = rig_mode(rig, n, c, T)
        write_record(logs / f"SYN-B-{int(T)}F.mcap", simulate_ringdown(rig, n, c, T, 0.025, f, z))
    c = (EA / l, eta_a / l, 80.0 / l, 0.5 / l)
    f, z, _, _ = rig_mode(ax, n, c, 70.0)
    write_record(logs / "SYN-A-70F.mcap", simulate_ringdown(ax, n, c, 70.0, 2e-4, f, z))
    out = tmp_path / "built"
    res = CliRunner().invoke(properties, ["build", "--logs", str(logs), "--out", str(out),
                                          "--hardware", str(tmp_path / "hardware.toml"),
                                          "--element-counts", "8,16", "--quiet"])
    assert res.exit_code == 0, res.output
    assert "verification (N=8, time simulation): 4/4 within" in res.output
    d = read_properties(out / "hose_properties.json")
    tuned = d["hoses"]["fa18_buddy"]["bending_tuning"]
    for T, (EI, eta) in truth.items():
        r = next(r for r in tuned if abs(r["temperature_F"] - T) < 1e-9 and r["n_elements"] == n)
        assert r["EI_equivalent_N_m2"] == pytest.approx(EI, rel=2e-3)
        # the records carry still-air damping that the linear tuning leaves to c_b
        assert r["eta_b_equivalent_N_m2_s"] == pytest.approx(eta, rel=1e-2)
    a = next(r for r in d["hoses"]["fa18_buddy"]["axial_tuning"] if r["n_elements"] == n)
    assert a["EA_equivalent_N"] == pytest.approx(EA, rel=2e-3)
    assert a["eta_a_equivalent_N_s"] == pytest.approx(eta_a, rel=1e-2)
    # a hose with no records is not derived unless its source was measured
    assert "kdc10_pod" not in d["tables"]
    # the report's "built by ... (code X)" reads code_version.git
    assert d["code_version"]["git"] == code_version() != ""
    assert any(k.endswith("properties/tune.py") for k in d["code_version"]["source_sha256"])


def test_cli_lookup_refuses_extrapolation_in_one_line():
    res = CliRunner().invoke(properties, ["lookup", "kc130_long", "80", "0.2"])
    assert res.exit_code != 0
    assert "outside the tested range" in res.output and "Traceback" not in res.output
    res = CliRunner().invoke(properties, ["lookup", "kc130_long", "80", "0.2", "--allow-extrapolation"])
    assert res.exit_code == 0 and "k_b =" in res.output


# ---- where a build writes -----------------------------------------------------------------

def _tiny_doc() -> dict:
    """What the build summary reads, without a build."""
    return {"format": store.FORMAT, "hoses": {}, "tables": {}, "verification_tolerance_pct":
            {"frequency": 0.5, "damping": 2.0},
            "verification": [{"hose": "h", "test": "bending", "temperature_F": 0.0, "n_elements": 8,
                              "frequency_error_pct": 0.1, "damping_error_pct": 0.2,
                              "within_tolerance": True}]}


def test_build_writes_under_out_and_leaves_the_committed_table(tmp_path, monkeypatch):
    committed = DEFAULT_PATH.read_bytes()
    monkeypatch.setattr(build, "build_properties", lambda *a, **k: _tiny_doc())
    monkeypatch.setattr(store, "DEFAULT_OUT", tmp_path / "default")
    # by default, a new folder per build
    for _ in range(2):
        res = CliRunner().invoke(properties, ["build", "--quiet"])
        assert res.exit_code == 0, res.output
    written = sorted((tmp_path / "default").glob("*/hose_properties.json"))
    assert len(written) == 2 and read_properties(written[0])["verification"]
    res = CliRunner().invoke(properties, ["build", "--quiet", "--out", str(tmp_path / "mine")])
    assert res.exit_code == 0 and (tmp_path / "mine" / "hose_properties.json").is_file()
    # another build's file is not replaced
    res = CliRunner().invoke(properties, ["build", "--quiet", "--out", str(tmp_path / "mine")])
    assert res.exit_code == 2 and "already there" in res.output and "Traceback" not in res.output
    res = CliRunner().invoke(properties, ["build", "--out", str(tmp_path), "--update-committed"])
    assert res.exit_code == 2 and "not both" in res.output
    assert DEFAULT_PATH.read_bytes() == committed


def test_build_refuses_an_unwritable_out_before_computing(tmp_path, monkeypatch):
    monkeypatch.setattr(build, "build_properties", lambda *a, **k: pytest.fail("computed anyway"))
    blocker = tmp_path / "file"
    blocker.write_text("x")
    res = CliRunner().invoke(properties, ["build", "--out", str(blocker / "sub")])
    assert res.exit_code == 2 and "cannot write there" in res.output


def test_report_names_the_code_that_built_the_committed_table(doc):
    git = doc["code_version"]["git"]
    assert git
    assert any(f"at code {git}" in getattr(b, "text", "") for b in properties_blocks(run_provenance()))


# ---- loaders read a file once per version of it -------------------------------------------

def _count_reads(monkeypatch, module, name):
    calls = []
    real = getattr(module, name)
    monkeypatch.setattr(module, name, lambda p: calls.append(p) or real(p))
    return calls


def _touch_later(p):
    """A time stamp one second on: a file system's coarse clock cannot hide the edit."""
    st = p.stat()
    os.utime(p, ns=(st.st_atime_ns, st.st_mtime_ns + 10 ** 9))


def test_hardware_is_read_once_until_the_file_changes(tmp_path, monkeypatch):
    p = tmp_path / "hardware.toml"
    text = (ROOT / "flighttest" / "logs" / "hardware.toml").read_text(encoding="utf-8")
    p.write_text(text, encoding="utf-8")
    calls = _count_reads(monkeypatch, hardware, "_read_hardware")
    first = load_hardware(p)
    assert load_hardware(p) is first and load_hardware(str(p)) is first and len(calls) == 1
    # an edit of the same size: the time stamp tells
    assert "density_kg_m3 = 810.0" in text
    p.write_text(text.replace("density_kg_m3 = 810.0", "density_kg_m3 = 790.0"), encoding="utf-8")
    _touch_later(p)
    edited = load_hardware(p)
    assert len(calls) == 2 and edited is not first and edited.fuel_density == 790.0


def test_property_library_is_read_once_until_the_file_changes(tmp_path, monkeypatch):
    p = tmp_path / "props.json"
    doc = {"format": store.FORMAT, "tables": {"h": small_table("h").to_dict()}}
    write_properties(doc, p)
    calls = _count_reads(monkeypatch, store, "_read_library")
    first = load_library(p)
    assert load_library(p) is first and len(calls) == 1
    # same size, new content and time stamp: read again
    doc["tables"]["h"] = small_table("h", temps=(-40.0, 0.0, 40.0, 61.0)).to_dict()
    write_properties(doc, p)
    _touch_later(p)
    edited = load_library(p)
    assert len(calls) == 2 and edited.table("h").temperature_range_F[1] == 61.0
