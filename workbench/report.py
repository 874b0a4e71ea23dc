"""The validation report: HTML (jinja2 templates in reports/templates) with
matplotlib figures, the same as PDF, results.json and JUnit XML."""
from __future__ import annotations

import datetime as _dt
import json
import math
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

import jinja2

from workbench.figures import case_figures

TEMPLATES = Path(__file__).resolve().parent.parent / "reports" / "templates"

# per case kind: the run metrics tabulated in the report (name, column header)
TABLE_METRICS = {
    "pitch_doublet": [("drogue_frequency_hz_log", "log f (Hz)"), ("drogue_frequency_hz_sim", "model f (Hz)"),
                      ("drogue_frequency_error_pct", "f error (%)"),
                      ("drogue_damping_ratio_log", "log zeta"), ("drogue_damping_ratio_sim", "model zeta"),
                      ("drogue_steady_z_m_log", "log z (m)"), ("drogue_steady_z_m_sim", "model z (m)"),
                      ("drogue_z_response_rms_error_m", "z response RMS err (m)")],
    "trail": [("drogue_steady_x_m_log", "log x (m)"), ("drogue_steady_x_m_sim", "model x (m)"),
              ("drogue_steady_z_m_log", "log z (m)"), ("drogue_steady_z_m_sim", "model z (m)"),
              ("trail_shape_rms_error_m", "shape RMS (m)"), ("trail_shape_max_error_m", "shape max (m)")],
    "ringdown_bending": [("test", "test"), ("temperature_F", "T (F)"), ("n_elements", "N"),
                         ("frequency_measured_hz", "test f (Hz)"), ("frequency_simulated_hz", "model f (Hz)"),
                         ("frequency_error_pct", "f error (%)"), ("damping_measured", "test zeta"),
                         ("damping_simulated", "model zeta"), ("damping_error_pct", "zeta error (%)"),
                         ("constants_extrapolated_in_temperature", "extrapolated")],
    "engagement": [("shape_rms_error_pre_contact_m", "shape RMS pre-contact (m)"),
                   ("shape_rms_error_engaged_m", "shape RMS engaged (m)"),
                   ("shape_rms_error_at_contact_m", "at contact"), ("shape_rms_error_at_slack_m", "slack"),
                   ("shape_rms_error_at_max_slack_wave_m", "max slack/wave"),
                   ("shape_rms_error_at_max_reel_takeup_m", "max take-up"),
                   ("shape_rms_error_at_refuelling_steady_m", "refuelling"),
                   ("shape_rms_error_at_disconnect_m", "disconnect"),
                   ("wave_speed_mps_log", "log wave (m/s)"), ("wave_speed_mps_sim", "model wave (m/s)"),
                   ("reel_delay_s_log", "log reel delay (s)"),
                   ("peak_slack_m", "peak slack (m)"), ("wave_amplitude_2m_from_tow_m", "wave at 2 m (m)"),
                   ("peak_tension_N", "peak tension (N)"), ("probe_load_peak_N", "peak probe load (N)")],
}


def fmt(v) -> str:
    if v is None:
        return "–"
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            return "–"
        a = abs(v)
        if a != 0 and (a >= 1e5 or a < 1e-3):
            return f"{v:.3g}"
        return f"{v:.4g}" if a < 100 else f"{v:.1f}"
    return str(v)


def _table1(case_json: dict) -> list[dict]:
    """The paper's Table 1 for our data: the drogue's fundamental frequency in
    flight (mean over the case's logs) and in each model variant, with errors."""
    runs = case_json["runs"]
    if case_json["kind"] != "pitch_doublet" or not runs:
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
    return [{"title": f"Table 1: drogue fundamental frequency (mean of {len(f_log)} doublets)",
             "header": ["", "drogue frequency (Hz)", "error (%)"], "rows": rows}]


def _tables(case_json: dict) -> list[dict]:
    return _table1(case_json) + _run_table(case_json)


def _run_table(case_json: dict) -> list[dict]:
    cols = TABLE_METRICS.get(case_json["kind"], TABLE_METRICS.get("ringdown_bending")
                             if case_json["kind"].startswith("ringdown") else [])
    if not cols or not case_json["runs"]:
        return []
    rows = [[r["variant"], r["log"]] + [r["metrics"].get(k) for k, _ in cols] for r in case_json["runs"]]
    return [{"title": "Results per run", "header": ["variant", "log"] + [h for _, h in cols], "rows": rows}]


def properties_section() -> dict:
    """What the hose property tables rest on: per hose, measured or derived,
    and every assumption no test checked (from the property document)."""
    from workbench.properties.store import read_properties
    doc = read_properties()
    parts = ["<p>Structural constants of every case marked <code>source = \"table\"</code> come from "
             "<code>cases/properties/hose_properties.json</code>, built by <code>workbench properties "
             f"build</code> (code {escape(str(doc['code_version'].get('git', '')))}).</p><ul>"]
    for hose, prov in sorted(doc["hoses"].items()):
        status = prov["status"]
        flag = (f"<b>DERIVED</b> from {escape(prov['derived_from'])} (never bench tested)"
                if status == "derived" else "measured on the bench")
        items = "".join(f"<li>{escape(a)}</li>" for a in prov.get("assumptions", []))
        parts.append(f"<li><b>{escape(hose)}</b>: {flag}<ul>{items}</ul></li>")
    parts.append("</ul>")
    return {"title": "Hose properties and their assumptions", "html": "".join(parts)}


def write_report(outcomes, results: dict, out_dir: Path, wall_s: float, extra_sections=()) -> dict[str, Path]:
    """Write report.html, report.pdf, results.json, junit.xml and figures/ under out_dir."""
    out_dir = Path(out_dir)
    fig_dir = out_dir / "figures"
    fig_dir.mkdir(parents=True, exist_ok=True)
    cases = []
    for oc, cj in zip(outcomes, results["cases"]):
        figs = [f"figures/{p.name}" for p in case_figures(oc, fig_dir)]
        cases.append({**cj, "figures": figs, "tables": _tables(cj)})
    gates = [g for c in cases for g in c["gates"]]
    findings = [f for c in cases for f in c["findings"]]
    env = jinja2.Environment(loader=jinja2.FileSystemLoader(str(TEMPLATES)), autoescape=True)
    ctx = {
        "title": "Hose-and-drogue validation report",
        "generated": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "code_version": results.get("code_version", "unknown"), "data_note": results.get("data_note", ""),
        "passed": results["passed"], "n_cases": len(cases), "n_runs": sum(len(c["runs"]) for c in cases),
        "n_gates": len(gates), "n_gates_passed": sum(g["passed"] for g in gates),
        "n_findings": len(findings), "n_findings_expected": sum(f["passed"] for f in findings), "wall_s": wall_s,
        "cases": cases, "sections": [properties_section(), *extra_sections], "fmt": fmt,
        "css": (TEMPLATES / "style.css").read_text(),
    }
    html = env.get_template("report.html.j2").render(**ctx)
    paths = {"html": out_dir / "report.html", "pdf": out_dir / "report.pdf",
             "json": out_dir / "results.json", "junit": out_dir / "junit.xml"}
    paths["html"].write_text(html, encoding="utf-8")
    _write_pdf(html, out_dir, paths["pdf"])
    paths["json"].write_text(json.dumps(results, indent=1) + "\n")
    paths["junit"].write_text(junit_xml(results))
    return paths


def _write_pdf(html: str, base: Path, path: Path) -> None:
    """The same document through xhtml2pdf; figures go in as data URIs, since
    the renderer will not read files outside the working folder."""
    import base64
    import logging
    import re

    from xhtml2pdf import pisa
    logging.getLogger("xhtml2pdf").setLevel(logging.ERROR)

    def inline(m):
        data = base64.b64encode((base / m.group(1)).read_bytes()).decode("ascii")
        return f'src="data:image/png;base64,{data}"'
    html = re.sub(r'src="(figures/[^"]+\.png)"', inline, html)
    with open(path, "wb") as fh:
        status = pisa.CreatePDF(html, dest=fh)
    if status.err:
        raise RuntimeError(f"{path}: PDF rendering failed ({status.err} errors)")


def junit_xml(results: dict) -> str:
    """One test case per gate and per finding (findings in their own class,
    `<case>.findings`), and one per case that failed to run."""
    cases = []
    fails = 0
    for c in results["cases"]:
        if c["error"]:
            fails += 1
            cases.append(f'<testcase classname={quoteattr(c["id"])} name="run">'
                         f'<failure message={quoteattr(c["error"])}/></testcase>')
        checks = ([(c["id"], g, gate_message(c["id"], g), g["source"]) for g in c["gates"]]
                  + [(f'{c["id"]}.findings', f, finding_message(c["id"], f), f["source"]) for f in c["findings"]])
        for classname, check, msg, source in checks:
            name = f'{check["variant"]}.{check["metric"]}'
            if check["passed"]:
                cases.append(f'<testcase classname={quoteattr(classname)} name={quoteattr(name)}/>')
            else:
                fails += 1
                cases.append(f'<testcase classname={quoteattr(classname)} name={quoteattr(name)}>'
                             f'<failure message={quoteattr(msg)}>{escape(source)}</failure></testcase>')
    return ('<?xml version="1.0" encoding="utf-8"?>\n'
            f'<testsuite name="workbench-validate" tests="{len(cases)}" failures="{fails}">\n'
            + "\n".join(cases) + "\n</testsuite>\n")


def gate_message(case_id: str, g: dict) -> str:
    op = "<=" if g["kind"] == "max" else ">="
    return (f"{case_id}: {g['metric']} ({g['variant']}) = {fmt(g['value'])}, "
            f"needs {op} {fmt(g['threshold'])}")


def finding_message(case_id: str, f: dict) -> str:
    return (f"{case_id}: finding {f['metric']} ({f['variant']}) = {fmt(f['value'])}, expected "
            f"{fmt(f['expected'])} +- {fmt(f['band'])} ({f['status']}: the reference model moved)")
