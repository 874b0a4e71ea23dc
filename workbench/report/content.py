"""What the validation report says, as blocks (`document`): the verdict page,
contents, glossary, the extra sections (hose properties, diagnosis), a page
per case, and the provenance of the whole run."""
from __future__ import annotations

import datetime as _dt

from workbench.provenance import ROOT, file_sha256
from workbench.report.document import (Cell, Contents, Document, Heading, Para, Table, anchor, esc, fmt)
from workbench.report.objective import objective_tables

# per case kind: the run metrics tabulated per run (name, row label)
TABLE_METRICS = {
    "pitch_doublet": [("drogue_frequency_hz_log", "flight f (Hz)"), ("drogue_frequency_hz_sim", "model f (Hz)"),
                      ("drogue_frequency_error_pct", "f error (%)"),
                      ("drogue_damping_ratio_log", "flight ζ (-)"), ("drogue_damping_ratio_sim", "model ζ (-)"),
                      ("drogue_steady_z_m_log", "flight z (m)"), ("drogue_steady_z_m_sim", "model z (m)"),
                      ("drogue_z_response_rms_error_m", "z response RMS error (m)")],
    "trail": [("drogue_steady_x_m_log", "flight x (m)"), ("drogue_steady_x_m_sim", "model x (m)"),
              ("drogue_steady_z_m_log", "flight z (m)"), ("drogue_steady_z_m_sim", "model z (m)"),
              ("trail_shape_rms_error_m", "shape RMS error (m)"), ("trail_shape_max_error_m", "shape max error (m)")],
    "ringdown": [("temperature_F", "T (°F)"), ("n_elements", "N"),
                 ("frequency_measured_hz", "bench f (Hz)"), ("frequency_simulated_hz", "model f (Hz)"),
                 ("frequency_error_pct", "f error (%)"), ("damping_measured", "bench ζ (-)"),
                 ("damping_simulated", "model ζ (-)"), ("damping_error_pct", "ζ error (%)"),
                 ("constants_extrapolated_in_temperature", "extrapolated")],
    "engagement": [("shape_rms_error_pre_contact_m", "shape RMS pre-contact (m)"),
                   ("shape_rms_error_engaged_m", "shape RMS engaged (m)"),
                   ("shape_rms_error_at_contact_m", "shape RMS at contact (m)"),
                   ("shape_rms_error_at_slack_m", "at slack (m)"),
                   ("shape_rms_error_at_max_slack_wave_m", "at max slack/wave (m)"),
                   ("shape_rms_error_at_max_reel_takeup_m", "at max take-up (m)"),
                   ("shape_rms_error_at_refuelling_steady_m", "at refuelling (m)"),
                   ("shape_rms_error_at_disconnect_m", "at disconnect (m)"),
                   ("wave_speed_mps_log", "flight wave speed (m/s)"), ("wave_speed_mps_sim", "model wave speed (m/s)"),
                   ("reel_delay_s_log", "flight reel delay (s)"),
                   ("peak_slack_m", "peak slack (m)"), ("wave_amplitude_2m_from_tow_m", "wave 2 m from tow (m)"),
                   ("peak_tension_N", "peak tension (N)"), ("probe_load_peak_N", "peak probe load (N)")],
}

GLOSSARY_VARIANTS = [
    ("baseline", "The case's model as written, when the case defines no variants."),
    ("no_lift", "The paper's reference model without the drogue's aerodynamic lift (lift scale 0)."),
    ("wt_lift", "The paper's reference model with the wind-tunnel drogue lift (lift scale 1)."),
    ("tuned_lift", "The drogue lift scale tuned (least squares on the static drogue height) on the logs the "
                   "variant names, and checked on the others; the paper's practice."),
    ("diagnosed", "The effects workbench diagnose found to explain the gap (e.g. the drogue lift, the tanker "
                  "wake), their parameters calibrated on the variant's training logs and gated on the others."),
    ("locked / constant_tension / measured", "The reel study's reel models: locked drum, the idealised "
                                             "constant-tension reel (paper Eq. 12), the flight reel's payout."),
]

GLOSSARY_TERMS = [
    ("gate", "An acceptance check the model must pass, on the runs held out from any tuning: value against "
             "threshold; margin = threshold − value for a maximum, value − threshold for a minimum (positive: "
             "passes)."),
    ("finding", "What a reference model gets wrong, with its expected value ± band and their sources; a value "
                "that leaves the band means the model changed, and fails validation like a gate."),
    ("14 CFR Part 60", "The flight simulator qualification standard's objective-test tolerances (period within "
                       "10 %, damping ratio within 0.02, time histories within stated bands), shown beside the "
                       "paper's gates for comparison."),
    ("f, ζ", "The drogue's (or bench hose's) fundamental frequency (Hz) and damping ratio, from the free decay "
             "(flighttest.analyze); period = 1/f."),
    ("steady x, y, z", "The drogue's mean position relative to the tow point (x aft, y right, z up, m) before the "
                       "excitation or contact."),
    ("shape RMS error", "RMS of the normal distances of the video hose points from the simulated hose (m), over "
                        "the steady trail, before contact, or engaged (contact to disconnect)."),
    ("z response RMS error", "RMS of the drogue's vertical response about its steady height, model minus "
                             "flight, through the doublet (m)."),
    ("wave speed", "Speed of the transverse wave down the hose after contact (m/s), from the timing of the "
                   "hose points' departure along the hose."),
    ("E, u_val", "ASME V&V 20: comparison error E = S − D (model minus data) and validation uncertainty "
                 "u_val = √(u_D² + u_num² + u_input²), a '–' left out. |E| ≤ u_val: the model is validated to the "
                 "level of u_val (its error cannot be told from the validation's uncertainty); |E| well above "
                 "u_val: E measures the model's error."),
    ("u_D", "The data's uncertainty: the sample standard deviation of D over repetitions (a bench setpoint's "
            "repeated ring-downs; the case's logs of the same test: three doublets, four trails, two "
            "engagements); for an RMS error, that error's spread over the case's logs. '–' with one repetition."),
    ("u_num", "The numerical error. A flight run: validate runs it again at half the elements and takes Roache's "
              "grid-convergence index GCI = Fs·|S − S_coarse| / (r^p − 1) with Fs = 3 (two grids), r = 2 and "
              "p = 2 (the solver's second-order convergence in the element length, tests/solver), read as a "
              "95 % bound: u_num = GCI / 2. A bench ring-down: the property tables' verification bound "
              "({frequency:g} % of the frequency, {damping:g} % of the damping; verification_tolerance_pct of "
              "cases/properties/hose_properties.json)."),
    ("u_input", "The input uncertainty of the steady drogue position: the static solve repeated with each test-card "
                "input moved by its 1-sigma (calibrated airspeed 1 kt and pressure altitude 25 ft of a "
                "flight-test air-data system, OAT 1 °C, tanker gross weight 1 %; the log schema states no "
                "accuracies), the changes root-sum-squared. Not measured ('–') for frequency, damping, response "
                "and shape errors, wave speed and reel delay, which would need a full run per input. The "
                "calibrated parameters' standard errors are printed with each diagnosed variant."),
]


def _link(case_id: str) -> str:
    return f'<a href="#case-{anchor(case_id)}">{esc(case_id)}</a>'


def _pf(passed: bool, yes="pass", no="FAIL") -> Cell:
    return Cell(yes if passed else no, "pass" if passed else "fail")


def verdict_blocks(results: dict, cases: list[dict], wall_s: float) -> list:
    gates = [g for c in cases for g in c["gates"]]
    findings = [f for c in cases for f in c["findings"]]
    ok = results["passed"]
    gate_rows = []
    for c in cases:
        for g in c["gates"]:
            op = "max" if g["kind"] == "max" else "min"
            gate_rows.append([Cell(_link(c["id"])), g["variant"], Cell(esc(g["metric"])), g["value"],
                              Cell(f"{op} {esc(fmt(g['threshold']))}"), g["margin"], _pf(g["passed"]),
                              Cell(esc(g["part60"] or "–"), "small"), Cell(esc(g["source"]), "small")])
        if c["error"]:
            gate_rows.append([Cell(_link(c["id"])), "–", Cell("did not run"), None, Cell("–"), None,
                              Cell("ERROR", "fail"), Cell("–"), Cell(esc(c["error"]), "small")])
    finding_rows = [[Cell(_link(c["id"])), f["variant"], Cell(esc(f["metric"])), f["value"], f["expected"],
                     Cell(f"&plusmn; {esc(fmt(f['band']))}"), _pf(f["passed"], f["status"], f["status"]),
                     Cell(esc(f["source"]), "small"), Cell(esc(f["band_source"]), "small")]
                    for c in cases for f in c["findings"]]
    return [
        Heading(1, "Verdict", "verdict"),
        Para(f"Overall: {'PASS' if ok else 'FAIL'} ({sum(g['passed'] for g in gates)} of {len(gates)} gates pass; "
             f"{sum(f['passed'] for f in findings)} of {len(findings)} findings as expected)",
             "verdict-pass" if ok else "verdict-fail"),
        Para(f"{len(cases)} cases, {sum(len(c['runs']) for c in cases)} runs, {wall_s:.1f} s; code "
             f"{esc(results.get('code_version', 'unknown'))}; generated "
             f"{_dt.datetime.now(_dt.timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}.", "meta"),
        Para(esc(results.get("data_note", "")), "note"),
        Table(["case", "variant", "metric", "value", "threshold", "margin", "result", "14 CFR Part 60", "source"],
              gate_rows, [12, 7, 16, 6, 6, 6, 5, 11, 31], title="Gates: acceptance checks",
              row_class="gate-row",
              note="A gate is an acceptance check the model must pass; its threshold cites its source, and the "
                   "Part 60 objective-test tolerance stands beside it where one exists."),
        Table(["case", "variant", "metric", "value", "expected", "band", "status", "source", "band source"],
              finding_rows, [13, 8, 15, 7, 7, 7, 8, 20, 15], title="Findings: what the reference models get wrong",
              row_class="finding-row",
              note="A finding documents an error of a reference model (the paper's baselines) with its expected "
                   "value and source; a value that leaves its band means the model changed."),
    ]


def glossary_blocks(bounds_pct: dict) -> list:
    return [Heading(1, "Glossary", "glossary"),
            Table(["variant", "meaning"], [[Cell(f"<b>{esc(k)}</b>"), Cell(esc(v))] for k, v in GLOSSARY_VARIANTS],
                  [25, 75], title="Model variants"),
            Table(["term", "meaning"], [[Cell(f"<b>{esc(k)}</b>"), Cell(esc(v.format(**bounds_pct)))]
                                        for k, v in GLOSSARY_TERMS], [20, 80], title="Metrics and terms")]


def properties_blocks(prov: dict) -> list:
    """What the hose property tables rest on: per hose, measured or derived,
    and every assumption no test checked (from the property document)."""
    from workbench.properties.store import read_properties
    doc = read_properties()
    table = prov["property_table"]
    rows = []
    for hose, p in sorted(doc["hoses"].items()):
        status = (f"<b>derived</b> from {esc(p['derived_from'])} (never bench tested)" if p["status"] == "derived"
                  else "measured on the bench")
        rows.append([Cell(f"<b>{esc(hose)}</b>"), Cell(status),
                     Cell("<br/>".join(f"• {esc(a)}" for a in p.get("assumptions", [])) or "–", "small")])
    return [Heading(1, "Hose properties and their assumptions", "hose-properties"),
            Para(f"Structural constants of every case with <i>source = \"table\"</i> come from {esc(table['file'])}, "
                 f"built by workbench properties build at code {esc(table['code_version'])}."),
            Table(["hose", "status", "assumptions no test checked"], rows, [15, 25, 60])]


def _kind(case: dict) -> str:
    return "ringdown" if case["kind"].startswith("ringdown") else case["kind"]


def table1(case: dict) -> list[Table]:
    """The paper's Table 1 for our data: the drogue's fundamental frequency in
    flight (mean over the case's logs) and in each model variant, with errors."""
    runs = case["runs"]
    if case["kind"] != "pitch_doublet" or not runs:
        return []
    logs = {}
    for r in runs:
        logs.setdefault(r["log"], r["metrics"].get("drogue_frequency_hz_log"))
    f_log = [v for v in logs.values() if v is not None]
    if not f_log:
        return []
    f_mean = float(sum(f_log) / len(f_log))
    rows = [["flight test data", f_mean, None]]
    for vid in dict.fromkeys(r["variant"] for r in runs):
        fs = [r["metrics"].get("drogue_frequency_hz_sim") for r in runs if r["variant"] == vid]
        fs = [v for v in fs if v is not None]
        if fs:
            f = float(sum(fs) / len(fs))
            rows.append([f"model: {vid}", f, 100.0 * (f - f_mean) / f_mean])
    return [Table(["", "drogue frequency (Hz)", "error (%)"], rows, [40, 30, 30],
                  title=f"Table 1: drogue fundamental frequency (mean of {len(f_log)} doublets)")]


def run_table(case: dict) -> list[Table]:
    """Every run's metrics: a row per run for ring-downs (many setpoints, few
    metrics), else a row per metric and a column per run (few runs, many metrics)."""
    cols = TABLE_METRICS.get(_kind(case), [])
    runs = case["runs"]
    if not cols or not runs:
        return []
    if _kind(case) == "ringdown":
        rows = [[r["log"]] + [r["metrics"].get(k) for k, _ in cols] for r in runs]
        return [Table(["setpoint"] + [h for _, h in cols], rows, [22] + [9] * len(cols),
                      title="Results per bench setpoint")]
    header = ["metric"] + [f"{esc(r['variant'])}<br/>{esc(r['log'])}" for r in runs]
    rows = [[Cell(esc(h))] + [r["metrics"].get(k) for r in runs] for k, h in cols]
    return [Table(header, rows, [24] + [76 / len(runs)] * len(runs), title="Results per run")]


def _calibration_paras(case: dict) -> list[Para]:
    out = []
    for vid, cal in (case.get("calibrated") or {}).items():
        params = "; ".join(f"{esc(e)}.{esc(k)} = {esc(fmt(v))} ± {esc(fmt(cal['stderr'][e][k]))}"
                           for e, ps in cal["effects"].items() for k, v in ps.items())
        out.append(Para(f"Variant <b>{esc(vid)}</b> calibrated on {esc(', '.join(cal['on']))} (the diagnosis's "
                        f"fit; training gap {esc(fmt(cal['gap_before']))} → {esc(fmt(cal['gap_train']))} m): "
                        f"{params} (± 1 standard error); gated on the other logs.", "meta"))
    for vid, v in (case.get("tuned") or {}).items():
        out.append(Para(f"Variant <b>{esc(vid)}</b>: drogue lift scale tuned to {esc(fmt(v))}.", "meta"))
    return out


def run_provenance(case: dict, log_hashes: dict) -> Table:
    rows = []
    for r in case["runs"]:
        opts = " ".join(f"{esc(k)}={esc(fmt(v))}" for k, v in r["model_options"].items())
        rows.append([r["variant"], Cell(esc(r["log_file"]), "small"),
                     Cell(esc(log_hashes.get(r["log_file"], "–")).replace(" ", "<br/>"), "small"), "yes" if r["held_out"] else "no",
                     Cell(opts, "small"), r["wall_s"]])
    return Table(["variant", "log file", "SHA-256", "held out", "model options", "wall (s)"], rows,
                 [9, 20, 36, 6, 22, 7], title="Runs: inputs and options")


def case_blocks(case: dict, figures: list, log_hashes: dict, bounds_pct: dict) -> list:
    gates = [[g["variant"], Cell(esc(g["metric"])), g["value"], Cell(f"{g['kind']} {esc(fmt(g['threshold']))}"),
              g["margin"], _pf(g["passed"]), Cell(esc(g["source"]), "small"),
              Cell(esc(g["part60"] or "–"), "small")] for g in case["gates"]]
    findings = [[f["variant"], Cell(esc(f["metric"])), f["value"], f["expected"],
                 Cell(f"&plusmn; {esc(fmt(f['band']))}"), _pf(f["passed"], f["status"], f["status"]),
                 Cell(esc(f["source"]), "small")] for f in case["findings"]]
    out = [Heading(1, esc(case["title"] or case["id"]), f"case-{anchor(case['id'])}"),
           Para(f"Case <b>{esc(case['id'])}</b> ({esc(case['kind'])}) from {esc(case['file'])}.", "meta"),
           *_calibration_paras(case)]
    if case["error"]:
        out.append(Para(f"This case did not run: {esc(case['error'])}", "fail"))
    if gates:
        out.append(Table(["variant", "metric", "value", "threshold", "margin", "result", "source",
                          "14 CFR Part 60"], gates, [10, 17, 8, 9, 8, 7, 28, 13], title="Gates"))
    if findings:
        out.append(Table(["variant", "metric", "value", "expected", "band", "status", "source"], findings,
                         [10, 17, 8, 8, 8, 10, 39], title="Findings"))
    out += objective_tables(case, bounds_pct)
    out += table1(case) + run_table(case)
    out += figures
    out.append(run_provenance(case, log_hashes))
    return out


def provenance_blocks(prov: dict) -> list:
    deps = ", ".join(f"{esc(k)} {esc(v or 'not installed')}" for k, v in prov["dependencies"].items())
    table = prov["property_table"]
    changed = table["code_changed_since"]
    return [Heading(1, "Provenance", "provenance"),
            Para(f"Code version {esc(prov['code_version'])} "
                 f"({'uncommitted changes in the tree' if prov['dirty'] else 'clean tree'}); Python "
                 f"{esc(prov['python'])}; {deps}."),
            Para(f"Property tables {esc(table['file'])} built by workbench properties build at code "
                 f"{esc(table['code_version'])}; "
                 + (f"the code that built them has changed since ({esc(', '.join(changed))})." if changed else
                    "the code that built them is unchanged since.")),
            Para("Paths are relative to the project folder; each run's log file is listed with its SHA-256 on "
                 "its case's page (and in results.json).", "note")]


def log_hashes(cases: list[dict]) -> dict[str, str]:
    """SHA-256 of every log file the runs name, by the name the run gives (a
    ring-down run names its records' files, comma-separated, found under the
    project's log folder; several hashes then, in that order)."""
    from workbench.hardware import DEFAULT_PATH
    out = {}
    for c in cases:
        for r in c["runs"]:
            name = r["log_file"]
            files = [ROOT / name] if (ROOT / name).is_file() else \
                [next(DEFAULT_PATH.parent.rglob(n), None) for n in name.split(", ")]
            if files and all(f is not None for f in files):
                out[name] = " ".join(file_sha256(f) for f in files)
    return out


def build_document(cases: list[dict], results: dict, wall_s: float, sections=(), case_figures=None) -> Document:
    doc = Document("Hose-and-drogue validation report")
    doc.add(*verdict_blocks(results, cases, wall_s))
    doc.add(Heading(1, "Contents", "contents"), Contents())
    from workbench.properties.store import read_properties
    bounds_pct = read_properties()["verification_tolerance_pct"]
    doc.add(*glossary_blocks(bounds_pct))
    doc.add(*properties_blocks(results["provenance"]))
    for s in sections:
        doc.add(*s)
    hashes = results["provenance"]["log_sha256"]
    for c in cases:
        doc.add(*case_blocks(c, (case_figures or {}).get(c["id"], []), hashes, bounds_pct))
    doc.add(*provenance_blocks(results["provenance"]))
    return doc

