"""The diagnosis's reporters: diagnosis.json, diagnosis.html and the blind
selftest's selftest.json, written where the CLI says; and the HTML section
validate's report embeds. Compute (`rank.diagnose`, `selftest.run_selftest`)
returns results; only this module writes them."""
from __future__ import annotations

import html as _html
import json
import math
from pathlib import Path

import numpy as np

from workbench.diagnosis.result import Diagnosis
from workbench.diagnosis.setup import NOISE_FACTOR, PARAM_PENALTY


def write_diagnosis(diag: Diagnosis, out_dir: Path) -> dict[str, Path]:
    """Write diagnosis.json and diagnosis.html under `out_dir`; their paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    js = _clean(diag.to_json())
    files = {"json": out_dir / "diagnosis.json", "html": out_dir / "diagnosis.html"}
    files["json"].write_text(json.dumps(js, indent=1) + "\n")
    sec = report_section(js)
    files["html"].write_text(f"<!doctype html><meta charset='utf-8'><title>{sec['title']}</title><body>"
                             f"<h1>{sec['title']}</h1>{sec['html']}</body>", encoding="utf-8")
    return files


def write_selftest(result: dict, out_dir: Path) -> Path:
    """Write the blind selftest's figures as selftest.json under `out_dir`."""
    path = Path(out_dir) / "selftest.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(result, indent=1, default=float) + "\n")
    return path


def _clean(v):
    if isinstance(v, float):
        return v if math.isfinite(v) else None
    if isinstance(v, dict):
        return {str(k): _clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_clean(x) for x in v]
    if isinstance(v, (np.floating, np.integer)):
        return _clean(v.item())
    if isinstance(v, np.bool_):
        return bool(v)
    if isinstance(v, np.ndarray):
        return _clean(v.tolist())
    return v


def _f(v, fmt="{:.3f}"):
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "&ndash;"
    return fmt.format(v)


def _params_text(c) -> str:
    """A diagnosis.json ranking entry's parameters (a single effect's without
    the effect's level) with their standard errors."""
    if not c.get("params"):
        return ""
    p, s = c["params"], c["param_stderr"]
    if len(c["effects"]) == 1:
        p, s = {c["effect"]: p}, {c["effect"]: s}
    return "; ".join(f"{e}.{k} = {v:.3g} &plusmn; {s[e][k]:.2g}" for e, d in p.items() for k, v in d.items())


def _where_paragraph(head: str, w: dict) -> str:
    """One log's where-map as a paragraph: channels, phases, stations, bands."""
    e = _html.escape
    cells = ", ".join(f"{e(k)} {_f(v['gap_m'])}/{_f(v['floor_m'])}{'' if v['real'] else ' (noise)'}"
                      for k, v in w["by_channel"].items())
    ph = ", ".join(f"{e(p['phase'])} {_f(p['gap_m'])}{'' if p['real'] else ' (noise)'}" for p in w["by_phase"])
    st = ""
    if w.get("by_station"):
        st = "; by station (m along the hose: mean residual) " + ", ".join(
            f"{r['station_from_m']:.0f}-{r['station_to_m']:.0f}: {r['mean_m']:+.2f}" for r in w["by_station"])
    bz = w["by_band"].get("drogue z", {})
    bands = ", ".join(f"{k} {_f(v['residual_m'])}/{_f(v['floor_m'])}" for k, v in bz.items())
    return (f"<p><b>{e(head)}</b>: gap {_f(w['gap_m'])} m (floor {_f(w['noise_floor_m'])}); by channel "
            f"(gap/floor) {cells}; by phase {ph}{st}; drogue z by band around "
            f"{_f(w['fundamental_hz'], '{:.2f}')} Hz (residual/log's own) {bands}.</p>")


def report_section(diag: dict, title: str = "Sim-to-real gap diagnosis") -> dict:
    """{"title", "html"} for validate's report (or diagnosis.html), from the
    diagnosis.json content (`Diagnosis.to_json()`, or the file read back)."""
    e = _html.escape
    parts = [f"<p>Gap per family (m, defined below), before and after each effect, calibrated on training "
             f"data and scored held out; ranked by held-out gap &times; (1 + {PARAM_PENALTY:g} per parameter). "
             f"A gap under {NOISE_FACTOR:g}&times; its noise floor is noise. Scheduler: "
             f"{e(str(diag.get('scheduler')))}.</p>"]
    for name, d in diag["families"].items():
        parts.append(f"<h3>{e(name)}: {e(', '.join(d['logs']))}</h3>")
        parts.append(f"<p>{e(d['gap_definition'])}. Baseline gap {_f(d['gap_before'])} m against a noise floor of "
                     f"{_f(d['noise_floor'])} m ({'real' if d['gap_real'] else 'within noise'}); held out by "
                     f"{e(d['held_out_scheme'])}; {d['n_elements']} elements; {d['wall_s']:.0f} s.</p>")
        rows = "".join(
            f"<tr><td>{i + 1}</td><td>{e(c['effect'])}{' (implausible: ' + e(c['implausible']) + ')' if c.get('implausible') else ''}"
            f"</td><td>{_params_text(c)}</td><td>{_f(c['gap_before'])}</td>"
            f"<td>{_f(c['gap_after_train'])}</td><td>{_f(c['gap_after_heldout'])}</td>"
            f"<td>{_f(100 * c['shrink_heldout'] if c.get('shrink_heldout') is not None else None, '{:.0f} %')}</td>"
            f"<td>{_f(c.get('probability'), '{:.2f}')}</td></tr>"
            for i, c in enumerate(d["ranking"]))
        parts.append("<table><tr><th>#</th><th>effect</th><th>parameters (&plusmn; 1 s.e.)</th><th>gap before</th>"
                     "<th>after, train</th><th>after, held out</th><th>held-out shrink</th><th>probability</th></tr>" + rows + "</table>")
        if d.get("failed"):
            parts.append("<p>Failed, not ranked: " + "; ".join(f"{e(c['effect'])} ({e(c['message'])})"
                                                              for c in d["failed"]) + ".</p>")
        parts.append(f"<p>Remaining after the best: {_f(d['remaining_unexplained']['gap_m'])} m, of which "
                     f"{_f(d['remaining_unexplained']['above_noise_m'])} m above the noise floor. Screen (share of "
                     f"the residual each effect's sensitivities span): "
                     + ", ".join(f"{e(k)} {v:.2f}" for k, v in d["screen"].items()) + ". Not calibrated: "
                     + "; ".join(f"{e(k)} ({e(v)})" for k, v in d["not_applicable"].items()) + ".</p>")
        for log, w in d["gap"].items():
            parts.append(_where_paragraph(f"{log}, baseline", w))
        for log, w in (d.get("gap_after_best") or {}).items():
            parts.append(_where_paragraph(f"{log}, with {d['ranking'][0]['effect']}", w))
    if diag.get("findings"):
        parts.append("<h3>Findings</h3><ul>" + "".join(f"<li>{e(s)}</li>" for s in diag["findings"]) + "</ul>")
    if diag.get("selftest"):
        s = diag["selftest"]
        kinds = "; ".join(f"{e(k)}: {v['n']} logs, top-1 {100 * v['top1']:.0f} %, median shrink "
                          f"{100 * v['median_shrink']:.0f} %" for k, v in s.get("by_kind", {}).items())
        parts.append(f"<h3>Proof on withheld effects</h3><p>{s['n']} generated logs (the solver with one library "
                     f"effect at random parameters, light turbulence, sensor noise and dropouts; "
                     f"{s.get('n_elements_truth', '?')} elements against the diagnosis's "
                     f"{s.get('n_elements_diagnosis', '?')}), effect withheld: right effect first in "
                     f"{100 * s['top1']:.0f} %, median held-out shrink {100 * s['median_shrink']:.0f} % "
                     f"(at least 70 % in {100 * s.get('share_shrink_ge_70pct', float('nan')):.0f} % of the logs); "
                     f"{kinds}; {s['wall_s']:.0f} s.</p>")
    return {"title": title, "html": "\n".join(parts)}
