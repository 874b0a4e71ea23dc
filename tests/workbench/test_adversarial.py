"""The adversarial corpus (issue 14, item 8): bad inputs of every kind, each
through the `workbench` command line, each refused with its exit code and ONE
line on stderr naming the file, key or option -- never a traceback, never a
number computed from it. Generated from the schemas (`workbench.cases.SCHEMA`,
`workbench.hardware.RANGES`, the log contract's metadata ranges), so a new
field is attacked as soon as it is declared.

Every case here is refused at load or check time, before any simulation
(`_no_simulation` makes one that reaches the solver fail loudly); the whole
corpus runs in well under a minute. `python3 -m pytest -q -s
tests/workbench/test_adversarial.py` prints the count of inputs tried, by
outcome."""
from __future__ import annotations

import json
import math
import os
import sys
import tomllib
from collections import Counter
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from solver.chain import DivergenceError
from workbench.cases import NUM, SCHEMA
from workbench.cli import cli
from workbench.errors import EXIT_BAD_INPUT, EXIT_INTERRUPTED
from workbench.hardware import RANGES as HW_RANGES
from workbench.outputs import LOCK, claim, safe_name

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "flighttest"))
import make_corrupt as MC  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
HARDWARE = ROOT / "flighttest" / "logs" / "hardware.toml"
TRAIL_LOG = ROOT / "flighttest" / "logs" / "flight" / "TR-KDC10-E7.mcap"
OUTCOMES: Counter = Counter()   # exit code -> inputs tried (printed at the end of the module)

# A valid case with every table and every array table, assumed structural
# constants (no property table) and no log: it loads and builds in milliseconds.
BASE = """
id = "adv-base"
title = "adversarial base case"
kind = "pitch_doublet"
description = "every table present"
logs = []

[hardware]
hose = "kdc10_pod"
drogue = "kdc10_pod"
reel = "kdc10_pod"
tanker = "kdc10"

[condition]
altitude_ft = 15050
airspeed_kcas = 254
hose_fuel = "full"
hose_length_ft = 75.0
oat_F = 1.7
tanker_gross_weight_lb = 410000
from_log = false

[model]
n_elements = 12
drogue_lift_scale = 1.0
drogue_drag_scale = 1.0
reel = "locked"
drogue_after_contact = "free"
probe_coupling_N_m = 2.0e5
probe_coupling_damping_ratio = 0.7
reel_torque_law = "constant_tension"
reel_torque_N_m = 100.0
hinge_damping_N_m_s = 0.0
hinge_friction_N_m = 0.0

[model.structure]
source = "nominal constants"
EI_N_m2 = 50.0
EA_N = 2.0e6
bending_damping_N_m2_s = 2.0
axial_damping_N_s = 300.0
temperature_F = 40.0
allow_extrapolation = false

[tow_motion]
kind = "sine_doublet"
amplitude_m = 0.3
period_s = 2.0
start_s = 1.0

[run]
duration_s = 0.5
record_dt_s = 0.01

[effects.drogue_lift]
scale = 1.0

[[variants]]
id = "base"
label = "the base"
drogue_lift_scale = 1.0
drogue_drag_scale = 1.0
reel = "locked"
tune_drogue_lift_on = []
calibrate = []
calibrate_on = []

[[gates]]
metric = "drogue_steady_z_error_m"
variant = "base"
logs = []
max = 1.0
min = -1.0
abs = true
source = "s"
part60 = "p"

[[findings]]
metric = "drogue_steady_x_error_m"
variant = "base"
logs = []
expected = 0.0
band = 1.0
source = "s"
band_source = "b"
"""
ARRAYS = ("variants", "gates", "findings")
# numeric fields with no physical range: thresholds and expectations of a metric
UNBOUNDED = {("gates", "max"), ("gates", "min"), ("findings", "expected")}


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v == math.inf else "-inf" if v == -math.inf else repr(v))
    if isinstance(v, (int, str)):
        return json.dumps(v) if isinstance(v, str) else str(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(v)


def dump(doc: dict) -> str:
    """A case dict as TOML (scalars, lists, tables, one level of sub-tables, arrays of tables)."""
    lines = [f"{k} = {_toml_value(v)}" for k, v in doc.items() if not isinstance(v, dict) and k not in ARRAYS]

    def table(name, t):
        lines.append(f"\n[{name}]")
        lines.extend(f"{k} = {_toml_value(v)}" for k, v in t.items() if not isinstance(v, dict))
        for k, v in t.items():
            if isinstance(v, dict):
                table(f"{name}.{k}", v)
    for k, v in doc.items():
        if isinstance(v, dict):
            table(k, v)
    for k in ARRAYS:
        for item in doc.get(k, []):
            lines.append(f"\n[[{k}]]")
            lines.extend(f"{kk} = {_toml_value(vv)}" for kk, vv in item.items())
    return "\n".join(lines) + "\n"


def base() -> dict:
    return tomllib.loads(BASE)


def _slot(doc: dict, table: str) -> dict:
    if table == "":
        return doc
    if table in ARRAYS:
        return doc[table][0]
    node = doc
    for part in table.split("."):
        node = node[part]
    return node


def edited(table: str, key: str, value=None, delete: bool = False) -> str:
    doc = base()
    slot = _slot(doc, table)
    if delete:
        slot.pop(key)
    else:
        slot[key] = value
    return dump(doc)


def _bad_values(table: str, key: str, f) -> list:
    """The attacks on one schema field: wrong types always; non-finite numbers;
    far outside on each side where the field has a range; a wrong choice."""
    kind = f.kind
    if kind is list:
        return ["not a list", [1, 2]]
    if kind is bool:
        return [1, "yes"]
    if kind is str:
        out = [1, True, ["a"]]
        if f.check is not None and f.check("bogus-choice"):
            out.append("bogus-choice")
        return out
    out = [math.nan, math.inf, -math.inf, True, "12", [1.0]]
    if kind is int:
        out += [12.5, 2 ** 62, -(2 ** 62)]
    if (table, key) not in UNBOUNDED:
        out += [v for v in (-1e30, 1e30) if f.check is not None and f.check(v)]
    return out


def _schema_attacks():
    for table, fields in SCHEMA.items():
        for key, f in fields.items():
            for v in _bad_values(table, key, f):
                yield pytest.param(table, key, v, id=f"[{table}].{key}={v!r}"[:80])


# (id, table, key, value, words the message must hold): the issue's named attacks
# and the just-outside edges of the fields a user is most likely to get wrong
NAMED = [
    ("supersonic airspeed", "condition", "airspeed_kcas", 800, "airspeed_kcas must be 0"),
    ("airspeed below flight", "condition", "airspeed_kcas", 1e-9, "airspeed_kcas must be 0"),
    ("negative airspeed", "condition", "airspeed_kcas", -10, "airspeed_kcas must be 0"),
    ("altitude above ISA tables", "condition", "altitude_ft", 1e6, "altitude_ft must lie in"),
    ("altitude below", "condition", "altitude_ft", -1001, "altitude_ft must lie in"),
    ("below absolute zero", "condition", "oat_F", -500.0, "oat_F must lie in"),
    ("implausibly cold", "condition", "oat_F", -131.0, "oat_F must lie in"),
    ("implausibly hot", "condition", "oat_F", 141.0, "oat_F must lie in"),
    ("0.01 ft hose", "condition", "hose_length_ft", 0.01, "hose_length_ft must lie in"),
    ("a mile of hose", "condition", "hose_length_ft", 5280.0, "hose_length_ft must lie in"),
    ("tanker weight 1e30", "condition", "tanker_gross_weight_lb", 1e30, "tanker_gross_weight_lb must lie in"),
    ("tanker weight 1 lb", "condition", "tanker_gross_weight_lb", 1.0, "tanker_gross_weight_lb must lie in"),
    ("drogue_lift_scale 50", "model", "drogue_lift_scale", 50, "drogue_lift_scale must lie in"),
    ("negative drag scale", "model", "drogue_drag_scale", -1.0, "drogue_drag_scale must lie in"),
    ("variant lift 50", "variants", "drogue_lift_scale", 50, "drogue_lift_scale must lie in"),
    ("damping 1e15", "model.structure", "bending_damping_N_m2_s", 1e15, "bending_damping_N_m2_s must lie in"),
    ("axial damping 1e15", "model.structure", "axial_damping_N_s", 1e15, "axial_damping_N_s must lie in"),
    ("EI 1e15", "model.structure", "EI_N_m2", 1e15, "EI_N_m2 must lie in"),
    ("EA zero", "model.structure", "EA_N", 0.0, "EA_N must lie in"),
    ("hose at absolute zero", "model.structure", "temperature_F", -459.67, "temperature_F must lie in"),
    ("n_elements 3", "model", "n_elements", 3, "n_elements must lie in 4..200"),
    ("n_elements 201", "model", "n_elements", 201, "n_elements must lie in 4..200"),
    ("hinge damping 1e15", "model", "hinge_damping_N_m_s", 1e15, "hinge_damping_N_m_s must lie in"),
    ("record_dt 1e-7", "run", "record_dt_s", 1e-7, "record_dt_s must lie in"),
    ("duration 0", "run", "duration_s", 0.0, "duration_s must lie in"),
    ("duration a year", "run", "duration_s", 3.15e7, "duration_s must lie in"),
    ("doublet of 1 km", "tow_motion", "amplitude_m", 1000.0, "amplitude_m must lie in"),
    ("zero period", "tow_motion", "period_s", 0.0, "period_s must lie in"),
    ("id escapes", "", "id", "../../escaped", "id must be"),
    ("id with slash", "", "id", "a/b", "id must be"),
    ("hidden id", "", "id", ".hidden", "id must be"),
    ("empty id", "", "id", "", "id must be"),
    ("id of 200 chars", "", "id", "x" * 200, "id must be"),
    ("variant id escapes", "variants", "id", "../v", "id must be"),
    ("gate metric unknown", "gates", "metric", "no_such_metric", "is not a pitch_doublet metric"),
    ("gate variant unknown", "gates", "variant", "nope", "names unknown variant 'nope'"),
    ("negative band", "findings", "band", -1.0, "band must not be negative"),
    ("effect lift 50", "effects.drogue_lift", "scale", 50.0, "[effects.drogue_lift] scale"),
    ("effect unknown param", "effects.drogue_lift", "gain", 1.0, "gain"),
]

# Combinations no single key refuses: checked when the model is built or the
# run is estimated, still before the solver runs.
COMBINED = [
    ("elements under 5 cm", {"condition": {"hose_length_ft": 10.0}, "model": {"n_elements": 200}},
     "elements; must be >= 0.05 m"),
    ("record step below the solver's", {"run": {"record_dt_s": 1e-4}}, "below the solver's stable step"),
    ("output over 2 GB", {"run": {"duration_s": 3600.0, "record_dt_s": 1e-3}, "model": {"n_elements": 200},
                          "condition": {"hose_length_ft": 300.0}}, "GB"),
    ("stiff and long: over 30 min", {"run": {"duration_s": 3600.0, "record_dt_s": 0.1},
                                     "model": {"n_elements": 200}, "condition": {"hose_length_ft": 300.0},
                                     "model.structure": {"EA_N": 1e9}}, "limit 30 min"),
    ("flight case without airspeed", {"condition": {"airspeed_kcas": 0}}, "airspeed_kcas must be given"),
    ("reel drum without a reel", {"model": {"reel": "drum"}, "hardware": {"reel": None}}, "needs [hardware] reel"),
    ("unknown hose", {"hardware": {"hose": "nope"}}, "no hose 'nope'"),
    ("unknown drogue", {"hardware": {"drogue": "nope"}}, "no drogue 'nope'"),
    ("structure source without constants", {"model.structure": {"source": "x", "EI_N_m2": None}},
     "EI_N_m2 and EA_N must be given"),
]


def _combined_text(changes: dict) -> str:
    doc = base()
    for table, kv in changes.items():
        slot = _slot(doc, table)
        for k, v in kv.items():
            if v is None:
                slot.pop(k, None)
            else:
                slot[k] = v
    return dump(doc)


@pytest.fixture(autouse=True)
def _no_simulation(monkeypatch):
    """Every input here must be refused before the solver runs."""
    def refuse(*_a, **_k):
        raise DivergenceError("an adversarial input reached the solver")
    # every run goes through the one simulate path (validate's lift tuning solves statics there too)
    monkeypatch.setattr("workbench.simulate.solve_static", refuse)


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def refused(res, *words, code=EXIT_BAD_INPUT):
    """The contract: `code`, one line on stderr holding `words`, no traceback."""
    OUTCOMES[res.exit_code] += 1
    assert res.exit_code == code, (res.exit_code, res.output)
    assert "Traceback" not in res.output
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def run_case_text(tmp_path, text: str | bytes, name="case.toml"):
    p = tmp_path / name
    p.write_bytes(text if isinstance(text, bytes) else text.encode())
    return p, invoke("run", p, "--out", tmp_path / "out")


def test_base_case_is_valid(tmp_path):
    """The corpus attacks a case that is otherwise good: the base reaches the solver."""
    p, res = run_case_text(tmp_path, dump(base()))
    assert "reached the solver" in res.output, res.output


@pytest.mark.parametrize("table,key,value", list(_schema_attacks()))
def test_schema_field_attack(tmp_path, table, key, value):
    p, res = run_case_text(tmp_path, edited(table, key, value))
    line = refused(res, str(p), key)
    assert f"[{table}]" in line or table == ""


@pytest.mark.parametrize("table,key", [pytest.param(t, k, id=f"[{t}].{k}") for t, fs in SCHEMA.items()
                                       for k, f in fs.items() if f.required])
def test_missing_required_key(tmp_path, table, key):
    p, res = run_case_text(tmp_path, edited(table, key, delete=True))
    refused(res, str(p), f"missing required key '{key}'")


@pytest.mark.parametrize("table", [t for t in SCHEMA if t not in ("",)])
def test_typo_key_in_every_table(tmp_path, table):
    key = next(iter(SCHEMA[table]))
    p, res = run_case_text(tmp_path, edited(table, key + "x", 1))
    refused(res, str(p), f"unknown key '{key}x'")


@pytest.mark.parametrize("name,table,key,value,words", NAMED, ids=[n[0] for n in NAMED])
def test_named_attack(tmp_path, name, table, key, value, words):
    doc = base()
    if table.startswith("effects."):
        doc["effects"][table.split(".", 1)[1]][key] = value
        text = dump(doc)
    else:
        text = edited(table, key, value)
    p, res = run_case_text(tmp_path, text)
    refused(res, str(p), words)


@pytest.mark.parametrize("name,changes,words", COMBINED, ids=[c[0] for c in COMBINED])
def test_combined_attack(tmp_path, name, changes, words):
    p, res = run_case_text(tmp_path, _combined_text(changes))
    refused(res, str(p), words)


def test_every_numeric_case_field_has_a_range():
    """A numeric field without a physical range on both sides is a hole in the
    edge (the thresholds of gates and findings excepted: any metric value)."""
    holes = [f"[{t}].{k}" for t, fs in SCHEMA.items() for k, f in fs.items()
             if f.kind in (NUM, int) and (t, k) not in UNBOUNDED | {("findings", "band")}
             and not (f.check and f.check(-1e30) and f.check(1e30))]
    assert holes == []


def _damaged():
    text = dump(base())
    raw = text.encode()
    out = {f"truncated at {n}": raw[:n] for n in (1, 10, 40, 120, 300, 700) if n < len(raw)}
    out.update({
        "binary garbage": bytes(range(256)) * 4,
        "NUL bytes": b"\x00" * 100,
        "latin-1 bytes": "id = \"caf\xe9\"\n".encode("latin-1"),
        "duplicate key": (text + '\nid = "again"\n').encode(),
        "duplicate table": (text + "\n[hardware]\nhose = \"x\"\n").encode(),
        "unclosed string": b'id = "abc\n',
        "table as array": text.replace("[hardware]", "[[hardware]]").encode(),
        "array table as table": text.replace("[[gates]]", "[gates]").encode(),
        "unknown table": (text + "\n[runn]\nx = 1\n").encode(),
        "unknown sub-table": (text + "\n[model.structur]\nx = 1\n").encode(),
        "empty file": b"",
        "only comments": b"# nothing\n",
        "effects not a table": text.replace("[effects.drogue_lift]\nscale = 1.0", "").encode() + b"effects = 3\n",
        "over 1 MB": text.encode() + b"#" * 1_100_000 + b"\n",
    })
    return out


DAMAGED = _damaged()


@pytest.mark.parametrize("name", DAMAGED)
def test_damaged_case_file(tmp_path, name):
    p, res = run_case_text(tmp_path, DAMAGED[name])
    refused(res, str(p))


def test_case_file_that_is_a_folder_or_missing(tmp_path):
    (tmp_path / "d.toml").mkdir()
    refused(invoke("run", tmp_path / "d.toml", "--out", tmp_path / "o"), "d.toml")
    refused(invoke("run", tmp_path / "none.toml", "--out", tmp_path / "o"), "none.toml", "not found")


def _hardware_attacks():
    doc = tomllib.loads(HARDWARE.read_text())
    for section, items in doc.items():
        entries = {"": items} if section == "fuel" else items
        for ident, sheet in entries.items():
            for key in sheet:
                if key not in HW_RANGES:
                    continue
                for v in (-1e30, 1e30, math.nan, math.inf, "x", True):
                    yield pytest.param(section, ident, key, v, id=f"{section}.{ident}.{key}={v!r}")


@pytest.mark.parametrize("section,ident,key,value", list(_hardware_attacks()))
def test_hardware_field_attack(tmp_path, section, ident, key, value):
    doc = tomllib.loads(HARDWARE.read_text())
    (doc[section] if section == "fuel" else doc[section][ident])[key] = value
    hw = tmp_path / "hardware.toml"
    hw.write_text(dump(doc))
    res = invoke("properties", "build", "--hardware", hw, "--out", tmp_path / "o", "--quiet")
    refused(res, str(hw), key)


HW_TEXT = HARDWARE.read_text()
HW_STRUCTURE = {
    "typo key": (HW_TEXT.replace("bench_section_length_m = 1.52", "bench_section_lenght_m = 1.52"),
                 "unknown key 'bench_section_lenght_m'"),
    "unknown table": (HW_TEXT + "\n[receiver.f18]\nmass_kg = 1\n", "unknown table [receiver]"),
    "sheet not a table": (HW_TEXT + "\n[reel]\nodd = 3\n", "[reel.odd] must be a table"),
    "section a number": ("hose = 3\n" + HW_TEXT.split("[hose.kc130_long]")[0], "[hose] must be a table"),
    "missing key": (HW_TEXT.replace("mass_kg = 29.5\n", ""), "missing 'mass_kg'"),
    "description a number": (HW_TEXT.replace('description = "wing-pod drogue"', "description = 3"),
                             "description must be a string"),
    "damaged": (HW_TEXT[:200], "not valid TOML"),
}


@pytest.mark.parametrize("name", HW_STRUCTURE)
def test_hardware_file_structure_attack(tmp_path, name):
    text, words = HW_STRUCTURE[name]
    hw = tmp_path / "hardware.toml"
    hw.write_text(text)
    refused(invoke("properties", "build", "--hardware", hw, "--out", tmp_path / "o"), str(hw), words)


def test_hardware_inner_diameter_over_outer(tmp_path):
    hw = tmp_path / "hardware.toml"
    hw.write_text(HARDWARE.read_text().replace("inner_diameter_m = 0.0508", "inner_diameter_m = 0.09", 1))
    refused(invoke("properties", "build", "--hardware", hw, "--out", tmp_path / "o"), "must be less than")


def test_hardware_file_over_the_size_limit(tmp_path):
    hw = tmp_path / "hardware.toml"
    hw.write_bytes(HARDWARE.read_bytes() + b"#" * 1_100_000)
    refused(invoke("properties", "build", "--hardware", hw, "--out", tmp_path / "o"), "byte limit")


def _file(folder: Path, data: bytes) -> Path:
    p = folder / "input.json"
    p.write_bytes(data)
    return p


# (verb arguments, words): every verb's options out of range; {t} is the test's folder
OPTIONS = {
    "run --duration 0": (lambda t: ["run", "CASE", "--duration", "0"], "--duration"),
    "run --duration -1": (lambda t: ["run", "CASE", "--duration", "-1"], "--duration"),
    "run --duration nan": (lambda t: ["run", "CASE", "--duration", "nan"], "--duration"),
    "run --duration inf": (lambda t: ["run", "CASE", "--duration", "inf"], "--duration"),
    "run --duration 1e9": (lambda t: ["run", "CASE", "--duration", "1e9"], "--duration"),
    "run --duration soon": (lambda t: ["run", "CASE", "--duration", "soon"], "--duration"),
    "run --effect unknown": (lambda t: ["run", "CASE", "--effect", "nope"], "--effect nope"),
    "run --effect out of range": (lambda t: ["run", "CASE", "--effect", "drogue_lift:scale=50"], "scale"),
    "run --effect nan": (lambda t: ["run", "CASE", "--effect", "drogue_lift:scale=nan"], "scale"),
    "run --effect not a number": (lambda t: ["run", "CASE", "--effect", "drogue_lift:scale=big"], "scale"),
    "run --effect no value": (lambda t: ["run", "CASE", "--effect", "drogue_lift:scale"], "key=value"),
    "run --effect unknown key": (lambda t: ["run", "CASE", "--effect", "drogue_lift:gain=1"], "gain"),
    "run --effect empty": (lambda t: ["run", "CASE", "--effect", ":scale=1"], "--effect"),
    "run --log damaged": (lambda t: ["run", "CASE", "--log", _file(t, b"not an mcap" * 10)], "not an MCAP"),
    "run --log of another kind": (lambda t: ["run", "CASE", "--log", TRAIL_LOG], "is not the kind"),
    "run --mcap under a file": (lambda t: ["run", "CASE", "--mcap", _file(t, b"x") / "run.mcap"], "--mcap"),
    "run --animate a folder": (lambda t: ["run", "CASE", "--animate", t], "--animate"),
    "compare --duration 0": (lambda t: ["compare", TRAIL_LOG, "--mcap", t / "c.mcap", "--duration", "0"],
                             "--duration"),
    "compare --duration nan": (lambda t: ["compare", TRAIL_LOG, "--mcap", t / "c.mcap", "--duration", "nan"],
                               "--duration"),
    "compare damaged log": (lambda t: ["compare", _file(t, b"\x89MCAP0\r\n"), "--mcap", t / "c.mcap"], "input.json"),
    "compare --mcap under a file": (lambda t: ["compare", TRAIL_LOG, "--mcap", _file(t, b"x") / "c.mcap"],
                                    "--mcap"),
    "compare unknown case": (lambda t: ["compare", TRAIL_LOG, "--mcap", t / "c.mcap", "--case", "nope"],
                             "no such case file"),
    "validate --workers 0": (lambda t: ["validate", "CASE", "--workers", "0"], "--workers"),
    "validate --workers -3": (lambda t: ["validate", "CASE", "--workers", "-3"], "--workers"),
    "validate --workers 100000": (lambda t: ["validate", "CASE", "--workers", "100000"], "--workers"),
    "validate --workers x": (lambda t: ["validate", "CASE", "--workers", "x"], "--workers"),
    "validate no such case": (lambda t: ["validate", t / "nope.toml"], "no such case file"),
    "validate no such name": (lambda t: ["validate", "no_such_case"], "no such case file"),
    "diagnose --n 0": (lambda t: ["diagnose", "--selftest", "--n", "0"], "--n"),
    "diagnose --n -5": (lambda t: ["diagnose", "--selftest", "--n", "-5"], "--n"),
    "diagnose --n 1e9": (lambda t: ["diagnose", "--selftest", "--n", "1000000000"], "--n"),
    "diagnose --n-elements 0": (lambda t: ["diagnose", "--selftest", "--n-elements", "0"], "--n-elements"),
    "diagnose --n-elements 5000": (lambda t: ["diagnose", "--selftest", "--n-elements", "5000"], "--n-elements"),
    "diagnose --workers 0": (lambda t: ["diagnose", "--selftest", "--workers", "0"], "--workers"),
    "diagnose --seed -1": (lambda t: ["diagnose", "--selftest", "--seed", "-1"], "--seed"),
    "diagnose no logs": (lambda t: ["diagnose", "--out", t / "d"], "give one or more LOG.mcap"),
    "diagnose --out and --update-committed": (
        lambda t: ["diagnose", TRAIL_LOG, "--out", t / "d", "--update-committed"], "--update-committed"),
    "diagnose missing log": (lambda t: ["diagnose", t / "nope.mcap"], "nope.mcap"),
    "properties lookup nan F": (lambda t: ["properties", "lookup", "fa18_buddy", "nan", "0.5"], "TEMPERATURE_F"),
    "properties lookup below absolute zero": (
        lambda t: ["properties", "lookup", "fa18_buddy", "--", "-500", "0.5"], "TEMPERATURE_F"),
    "properties lookup zero length": (lambda t: ["properties", "lookup", "fa18_buddy", "70", "0"],
                                      "ELEMENT_LENGTH_M"),
    "properties lookup inf length": (lambda t: ["properties", "lookup", "fa18_buddy", "70", "inf"],
                                     "ELEMENT_LENGTH_M"),
    "properties lookup unknown hose": (lambda t: ["properties", "lookup", "nohose", "70", "0.5"], "nohose"),
    "properties build counts 0": (lambda t: ["properties", "build", "--element-counts", "0,8",
                                             "--out", t / "o"], "--element-counts"),
    "properties build counts 100000": (lambda t: ["properties", "build", "--element-counts", "8,100000",
                                                  "--out", t / "o"], "--element-counts"),
    "properties build counts x": (lambda t: ["properties", "build", "--element-counts", "8,x",
                                             "--out", t / "o"], "--element-counts"),
    "properties build --out and --update-committed": (
        lambda t: ["properties", "build", "--out", t / "o", "--update-committed"], "--update-committed"),
    "properties lookup --file /dev/zero": (
        lambda t: ["properties", "lookup", "fa18_buddy", "70", "0.5", "--file", "/dev/zero"], "is not a file"),
    "properties lookup --file damaged": (
        lambda t: ["properties", "lookup", "fa18_buddy", "70", "0.5", "--file", _file(t, b"{not json")],
        "not valid JSON"),
    "validate --diagnosis /dev/zero": (lambda t: ["validate", "CASE", "--diagnosis", "/dev/zero"], "is not a file"),
    "validate --diagnosis damaged": (lambda t: ["validate", "CASE", "--diagnosis", _file(t, b"\xff\xfe")],
                                     "not UTF-8"),
    "validate --diagnosis not a diagnosis": (lambda t: ["validate", "CASE", "--diagnosis", _file(t, b"[1]")],
                                             "not a diagnosis.json"),
    "logs inspect missing": (lambda t: ["logs", "inspect", t / "nope.mcap"], "nope.mcap"),
    "logs analyze missing": (lambda t: ["logs", "analyze", t / "nope.mcap"], "nope.mcap"),
}


@pytest.mark.parametrize("name", OPTIONS)
def test_option_out_of_range(tmp_path, name):
    args, words = OPTIONS[name]
    case = tmp_path / "case.toml"
    case.write_text(dump(base()))
    argv = [case if a == "CASE" else a for a in args(tmp_path)]
    if argv[0] in ("run", "validate") and "--out" not in argv:
        argv += ["--out", tmp_path / "out"]
    refused(invoke(*argv), words)


# the test card's numeric keys out of their physical range (flighttest.schema), in a small generated log
LOG_ATTACKS = {
    "airspeed 1e-9": {"airspeed_kcas": "1e-9"}, "supersonic": {"airspeed_kcas": "900"},
    "altitude 1e6 ft": {"altitude_ft": "1e6"}, "OAT -1000 F": {"oat_F": "-1000"},
    "OAT nan": {"oat_F": "nan"}, "hose 0.01 ft": {"hose_length_ft": "0.01"},
    "tanker 1e30 lb": {"tanker_gross_weight_lb": "1e30"}, "airspeed text": {"airspeed_kcas": "fast"},
    "unknown key": {"speed": "1"}, "unknown kind": {"test_kind": "barrel_roll"},
}


@pytest.mark.parametrize("verb", ["logs inspect", "logs analyze", "diagnose"])
@pytest.mark.parametrize("name", LOG_ATTACKS)
def test_log_with_out_of_range_metadata(tmp_path, verb, name):
    log = tmp_path / "bad.mcap"
    log.write_bytes(MC._meta("trail", **LOG_ATTACKS[name]))
    argv = verb.split() + [log] + (["--out", tmp_path / "d"] if verb == "diagnose" else [])
    refused(invoke(*argv), "bad.mcap", next(iter(LOG_ATTACKS[name])))


def test_case_against_another_hoses_log_is_refused_not_gated(tmp_path):
    """A case whose hose differs from the log's test card: exit 2 before any
    simulation (the no-simulation fixture), naming both hoses."""
    doc = base()
    doc["logs"] = [str(TRAIL_LOG)]
    doc["kind"] = "trail"
    doc["hardware"]["hose"] = "fa18_buddy"
    doc["gates"][0]["metric"] = "trail_shape_rms_error_m"
    doc["findings"] = []
    p = tmp_path / "mismatch.toml"
    p.write_text(dump(doc))
    res = invoke("validate", p, "--out", tmp_path / "o", "--no-progress")
    refused(res, "hose 'fa18_buddy' differs from the log's hose 'kdc10_pod'")


def test_two_cases_with_one_id_are_refused(tmp_path):
    a, b = tmp_path / "a.toml", tmp_path / "b.toml"
    a.write_text(dump(base()))
    b.write_text(dump(base()))
    refused(invoke("validate", a, b, "--out", tmp_path / "o", "--no-progress"), "adv-base", "ids must be unique")


def test_out_that_is_a_file_or_under_a_file(tmp_path):
    case = tmp_path / "case.toml"
    case.write_text(dump(base()))
    f = tmp_path / "file"
    f.write_text("x")
    refused(invoke("run", case, "--out", f), "--out", "is a file")
    refused(invoke("run", case, "--out", f / "sub"), "--out", "cannot write there")
    refused(invoke("validate", case, "--out", f / "sub", "--no-progress"), "--out", "cannot write there")
    refused(invoke("diagnose", TRAIL_LOG, "--out", f / "sub"), "--out", "cannot write there")


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes anywhere")
def test_unwritable_out(tmp_path):
    case = tmp_path / "case.toml"
    case.write_text(dump(base()))
    ro = tmp_path / "ro"
    ro.mkdir(mode=0o500)
    refused(invoke("run", case, "--out", ro), "--out", "cannot write there")


def test_a_folder_holding_another_runs_results_is_refused_without_force(tmp_path):
    case = tmp_path / "case.toml"
    case.write_text(dump(base()))
    out = tmp_path / "o"
    (out / "adv-base").mkdir(parents=True)
    refused(invoke("run", case, "--out", out), "another run's results", "--force")
    (out / "results.json").write_text("{}")
    refused(invoke("validate", case, "--out", out, "--no-progress"), "results.json", "--force")
    (out / "diagnosis.json").write_text("{}")
    refused(invoke("diagnose", TRAIL_LOG, "--out", out), "diagnosis.json", "--force")


def test_a_folder_another_run_is_writing_is_refused(tmp_path):
    """Two runs into one folder: the second sees the first's lock (a live process)."""
    case = tmp_path / "case.toml"
    case.write_text(dump(base()))
    out = tmp_path / "o"
    with claim(out):
        assert (out / LOCK).read_text().split()[0] == str(os.getpid())
        refused(invoke("run", case, "--out", out), "another run", str(os.getpid()))
        refused(invoke("validate", case, "--out", out, "--no-progress"), "another run")
    assert not (out / LOCK).exists()


def test_a_lock_left_by_a_killed_run_is_taken_over(tmp_path):
    import subprocess
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (tmp_path / LOCK).write_text(f"{dead.pid}\n")
    with claim(tmp_path) as out:
        assert (out / LOCK).read_text().split()[0] == str(os.getpid())


@pytest.mark.parametrize("text,name", [("../../escaped", "_.._escaped"), ("a/b", "a_b"), (".hidden", "hidden"),
                                       ("", "_"), ("..", "_"), ("RD-KC130-B-70F-r1", "RD-KC130-B-70F-r1"),
                                       ("x\x00y", "x_y")])
def test_safe_name_keeps_ids_inside_their_folder(tmp_path, text, name):
    assert safe_name(text) == name
    assert (tmp_path / safe_name(text)).resolve().parent == tmp_path.resolve()


def test_figure_named_by_an_escaping_test_id_stays_in_its_folder(tmp_path):
    from workbench.report.document import Figure
    from workbench.report.figures import save_pngs
    (path,) = save_pngs([Figure(b"\x89PNG", "", "case-../../escaped-trail")], tmp_path / "figures")
    assert path.parent == tmp_path / "figures" and path.exists()
    assert not (tmp_path / "escaped-trail.png").exists()


def test_diagnose_without_out_writes_a_new_folder_not_the_committed_one():
    from workbench.cli.diagnose import COMMITTED, _out_folder
    a = _out_folder(None, False)
    assert a != COMMITTED and a.parent == ROOT / "reports" / "out" and a.name.startswith("diagnose-")
    assert _out_folder(None, True) == COMMITTED


def test_ctrl_c_exits_130_with_one_line(tmp_path, monkeypatch):
    def interrupt(*_a, **_k):
        raise KeyboardInterrupt
    monkeypatch.setattr("workbench.case_run.run_case", interrupt)
    case = tmp_path / "case.toml"
    case.write_text(dump(base()))
    refused(invoke("run", case, "--out", tmp_path / "o"), "interrupted", code=EXIT_INTERRUPTED)
    assert not (tmp_path / "o" / LOCK).exists()      # the lock goes with the run


# -- random edits of a valid case: never a traceback, never exit 4 --------------
LINES = dump(base()).splitlines()
_value = st.one_of(st.integers(-10 ** 20, 10 ** 20).map(str), st.floats(allow_nan=True).map(_toml_value),
                   st.booleans().map(_toml_value), st.text(max_size=12).map(json.dumps),
                   st.sampled_from(['"../../x"', "[1, 2]", '["a"]', "{a = 1}", "1979-05-27", '""']))
_edit = st.one_of(
    st.tuples(st.just("delete"), st.integers(0, len(LINES) - 1), st.none()),
    st.tuples(st.just("duplicate"), st.integers(0, len(LINES) - 1), st.none()),
    st.tuples(st.just("value"), st.integers(0, len(LINES) - 1), _value),
    st.tuples(st.just("bytes"), st.integers(0, len(LINES) - 1), st.binary(min_size=1, max_size=8)),
    st.tuples(st.just("rename"), st.integers(0, len(LINES) - 1), st.text("abcdefgh_", min_size=1, max_size=6)),
)
FUZZ: Counter = Counter()


def _apply(lines: list[bytes], edit) -> list[bytes]:
    op, i, arg = edit
    i %= len(lines)
    line = lines[i]
    if op == "delete":
        return lines[:i] + lines[i + 1:]
    if op == "duplicate":
        return lines[:i + 1] + [line] + lines[i + 1:]
    if op == "bytes":
        return lines[:i] + [line[:len(line) // 2] + arg + line[len(line) // 2:]] + lines[i + 1:]
    if b"=" not in line:
        return lines
    key, _, val = line.partition(b"=")
    if op == "value":
        return lines[:i] + [key + b"= " + arg.encode()] + lines[i + 1:]
    return lines[:i] + [arg.encode() + b" =" + val] + lines[i + 1:]


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(edits=st.lists(_edit, min_size=1, max_size=4))
def test_random_case_edits_never_give_a_traceback(tmp_path_factory, edits):
    lines = [ln.encode() for ln in LINES]
    for e in edits:
        lines = _apply(lines, e) or [b""]
    d = tmp_path_factory.mktemp("fuzz")
    p = d / "case.toml"
    p.write_bytes(b"\n".join(lines) + b"\n")
    res = invoke("run", p, "--out", d / "o")
    # 4 (a defect) or a traceback is the failure; "reached the solver" (the
    # fixture's stand-in divergence, exit 3) is a valid edit, counted as 0
    ok = "reached the solver" in res.output
    FUZZ[0 if ok else res.exit_code] += 1
    OUTCOMES[0 if ok else res.exit_code] += 1
    assert ok or res.exit_code in (1, 2, 3), res.output
    assert "Traceback" not in res.output
    if not ok:
        assert len(res.stderr.strip().splitlines()) == 1, res.stderr


def test_zz_outcome_counts():
    """The count of bad inputs tried, by outcome (printed with -s); every one clean."""
    print(f"\nadversarial inputs tried: {sum(OUTCOMES.values())}, by exit code: {dict(sorted(OUTCOMES.items()))}; "
          f"random edits: {dict(sorted(FUZZ.items()))} (0: a valid edit, reached the solver)")
    assert set(OUTCOMES) <= {0, 1, 2, 3, EXIT_INTERRUPTED}
