"""The diagnosis's reporters: diagnosis.json, diagnosis.html and the blind
selftest's selftest.json, written where the CLI says; and the section
validate's report embeds, as report blocks (`workbench.report.document`) so
that diagnosis.html, validate's HTML and its PDF render it alike. Compute
(`rank.diagnose`, `selftest.run_selftest`) returns results; only this module
writes them.

The section draws from diagnosis.json alone: the where-map as heat maps
(gap over noise floor by channel, phase, station and band), the ranking as a
table and the calibrated parameters with their standard errors, the gap per
channel before and after the best explanation, and the selftest's confusion
matrix. Per log, channel x phase and (the hose) station x band heat maps
before and after the best explanation, and the log, the baseline and the best
explanation overlaid (the drogue channel with the largest gap over time, or a
trail's hose mean shape), from the where-map's tables and thinned series; a
diagnosis.json written before those keys existed renders without these
figures, with a note saying so."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from workbench.diagnosis.identify import PARALLEL_COS
from workbench.diagnosis.result import Diagnosis, added_label
from workbench.diagnosis.fleet import FLEET_PATH, text as fleet_text
from workbench.provenance import ROOT, code_version, file_sha256
from workbench.report.document import (Cell, Contents, Document, Figure, Heading, Para, Table, anchor, esc,
                                       figure_png, fmt, legend_below)
from workbench.diagnosis.setup import NOISE_FACTOR, PARAM_PENALTY


def write_diagnosis(diag: Diagnosis, out_dir: Path) -> dict[str, Path]:
    """Write diagnosis.json and diagnosis.html under `out_dir`; their paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    js = _clean(diag.to_json())
    files = {"json": out_dir / "diagnosis.json", "html": out_dir / "diagnosis.html"}
    files["json"].write_text(json.dumps(js, indent=1) + "\n")
    files["html"].write_text(diagnosis_html(js), encoding="utf-8")
    return files


def diagnosis_html(js: dict) -> str:
    """diagnosis.html from the diagnosis.json content: validate's templates and
    style, the figures inline, and the provenance of the inputs and the code."""
    from workbench.report import run_provenance
    from workbench.report.html import render_html
    doc = Document("Sim-to-real gap diagnosis").add(Contents(), *report_blocks(js))
    doc.add(*diagnosis_provenance(js, run_provenance()))
    return render_html(doc)


def write_fleet(diag: Diagnosis, source: str, path: Path = FLEET_PATH) -> Path:
    """Write the fleet calibrations `diag` (a diagnosis of the program's logs
    against the data sheets) establishes, `fleet.text`, to `path`; `source`
    says how it was made. Its path."""
    path = Path(path)
    path.write_text(fleet_text(diag, f"{source} (code {code_version()})"))
    return path


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




def _params_text(c) -> str:
    """A ranking entry's parameters (a single effect's without the effect's
    level) with their standard errors, as inline markup."""
    if not c.get("params"):
        return "–"
    p, s = c["params"], c["param_stderr"]
    if len(c["effects"]) == 1:
        p, s = {c["effect"]: p}, {c["effect"]: s}
    return "<br/>".join(f"{esc(e)}.{esc(k)} = {v:.3g} ± {s[e][k]:.2g}" for e, d in p.items() for k, v in d.items())


def _shares_text(c) -> str:
    """A selected set's shares of the gap, as inline text after its name."""
    if not c.get("shares"):
        return ""
    return " (shares of the gap: " + ", ".join(f"{esc(e)} {100 * v:.0f} %" for e, v in c["shares"].items()) + ")"


def _step_label(s: dict) -> str:
    """What a selection step did: the effect it added, the form parameters it
    refined, the effect it removed or the trade for fewer events."""
    if "added" in s:
        return added_label(s)
    return next(f"{k}: {s[k]}" for k in ("refined", "removed", "traded") if k in s)


def _verdict(s: dict) -> str:
    """A step's verdict, and for a refused one why; a diagnosis.json written
    before steps kept their reason says only that it was refused."""
    if s["accepted"]:
        return "accepted"
    return f"refused: {s['why']}" if s.get("why") else "refused"


def _selection_blocks(d: dict) -> list:
    """The forward selection: each step's change (its best addition; then
    what the revision refined, removed or traded), its gain against the gap
    it started from, the verdict and the share; and why it stopped. A
    diagnosis.json written before forward selection has none."""
    sel = d.get("selection")
    if not sel:
        return []
    rows = [[s["step"], Cell(esc(_step_label(s))), s["gap_heldout_before_m"], s["gap_heldout_after_m"], s["gain_m"],
             s["new_params"], Cell(esc(_verdict(s))),
             None if s["share"] is None else 100 * s["share"]] for s in sel["steps"]]
    return [Table(["step", "change", "held-out gap before (m)", "after (m)", "gain (m)", "new parameters",
                   "verdict", "share of the gap (%)"], rows, [5, 18, 10, 9, 9, 8, 32, 9],
                  title="Forward selection"),
            Para(f"Selected: {esc(' + '.join(sel['effects']) or 'none')}; stopped: {esc(sel['stopped'])}.")]


def _reel_blocks(d: dict) -> list:
    """The take-up against the reel's reference response (`reel`): the verdict,
    its probability, and each log's misfit and own response; none where the
    reel was not measured."""
    ev = d.get("reel")
    if not ev:
        return []
    def response(r: dict) -> list:
        # the dead time to the millisecond: a fit on its bound of 0 returns round-off (1e-19 s)
        return [Cell(f"{r['delay_s']:.3f}"), r["natural_frequency_rad_s"], r["damping_ratio"], r["gain"]]

    rows = [[Cell(esc(log)), ev["misfit_m"][log]] + response(o) for log, o in ev["own"].items()]
    ref = ev["reference"]
    rows.append([Cell(f"reference ({esc(', '.join(ref['logs']))})"), ref["everyday_misfit_m"]] + response(ref))
    return [Para(f"Reel lag, from the reel channel (the payout is prescribed, so it cuts none of the gap): "
                 f"{esc(ev['why'])}; the probability that the reel took up the hose otherwise than the program's "
                 f"reel: {fmt(ev['probability'])}."),
            Table(["log", "take-up misfit, RMS (m)", "dead time (s)", "natural frequency (rad/s)", "damping ratio",
                   "gain"], rows, [30, 14, 14, 14, 14, 14],
                  title="Reel take-up against the receiver's closure (the reference's misfit: its everyday one)")]


def _remainder_blocks(d: dict) -> list:
    """What the best explanation leaves, per channel (and hose station where a
    steady part is common to every log): steady and varying parts against the
    noise floor, and whether it is model form. A diagnosis.json written before
    the remainder was reported has none."""
    rem = d.get("remainder")
    if not rem:
        return []
    entries = [(k, v) for k, v in rem.items() if k != "hose stations"]
    entries += [(f"hose at {k}", v) for k, v in rem.get("hose stations", {}).items() if v["common"]]
    rows = [[Cell(esc(k)), v["steady_m"], v["varying_m"], v["floor_m"],
             Cell("model form: the same in every log" if v["common"] else "–")] for k, v in entries]
    return [Table(["where", "steady, mean over the logs (m)", "varying (m)", "noise floor (m)", "verdict"], rows,
                  [24, 16, 12, 12, 30], title="What the best explanation leaves")]


def _over(g, f) -> float:
    """Gap `g` over noise floor `f`; NaN (a blank cell) where either is
    missing or the floor is zero: a split of the residual whose every
    component the model's reproducibility weights left out, floor and all
    (`evaluate.evaluate`; measured: the tracker-phase signature of a
    proving-ground doublet, 486046539, where the division had ended the
    report)."""
    return math.nan if g is None or not f else g / f


def _size(v) -> float:
    """|v|; NaN where the band was not measured (a log too short for it)."""
    return math.nan if v is None else abs(v)


def _scale_top(*ratios) -> float:
    """The top of a heat map's colour scale: the largest finite ratio of
    `ratios` (arrays), at least 2 (NaN cells are blank, an all-blank map
    keeps 2)."""
    return max([2.0] + [float(np.nanmax(r)) for r in ratios if np.isfinite(r).any()])


def _heat(ax, values, rows, cols, title, annotate, vmax=None):
    """A heat map of gap / noise floor (log colour scale up to `vmax`, default
    `_scale_top` of the values), each cell annotated; NaN cells blank."""
    from matplotlib.colors import LogNorm
    v = np.array(values, float)
    im = ax.imshow(np.clip(v, 0.1, None), aspect="auto", cmap="viridis",
                   norm=LogNorm(vmin=0.5, vmax=vmax or _scale_top(v)))
    ax.set_xticks(range(len(cols)), cols, rotation=30, ha="right", fontsize=7)
    ax.set_yticks(range(len(rows)), rows, fontsize=7)
    ax.set_title(title, fontsize=9)
    for i in range(v.shape[0]):
        for j in range(v.shape[1]):
            if np.isfinite(v[i, j]):
                ax.text(j, i, annotate[i][j], ha="center", va="center", fontsize=6,
                        color="white" if v[i, j] < 30 else "black")
    return im


def _where_figure(name: str, d: dict):
    """Heat maps of one family's baseline where-map: per log, each channel's,
    phase's and station's gap over its noise floor, and per channel the
    residual in each frequency band (mean over the logs) over the floor."""
    from matplotlib.figure import Figure as MplFigure
    logs = list(d["gap"])
    maps = [d["gap"][k] for k in logs]
    panels = []
    chans = list(maps[0]["by_channel"])
    panels.append(("by channel", chans,
                   [[_over(m["by_channel"][c]["gap_m"], m["by_channel"][c]["floor_m"]) for c in chans] for m in maps],
                   [[m["by_channel"][c]["gap_m"] for c in chans] for m in maps]))
    phases = [p["phase"] for p in maps[0]["by_phase"]]
    if len(phases) > 1:
        panels.append(("by phase", phases, [[_over(p["gap_m"], p["floor_m"]) for p in m["by_phase"]] for m in maps],
                       [[p["gap_m"] for p in m["by_phase"]] for m in maps]))
    if maps[0].get("by_station"):
        st = [f"{r['station_from_m']:.0f}-{r['station_to_m']:.0f} m" for r in maps[0]["by_station"]]
        panels.append(("by station along the hose", st,
                       [[_over(r["gap_m"], r["floor_m"]) for r in m["by_station"]] for m in maps],
                       [[r["gap_m"] for r in m["by_station"]] for m in maps]))
    bchan = list(maps[0]["by_band"])
    bands = list(maps[0]["by_band"][bchan[0]])
    band_ratio = [[np.mean([_over(_size(m["by_band"][c][b]["residual_m"]), m["by_band"][c][b]["floor_m"])
                            for m in maps])
                   for b in bands] for c in bchan]
    band_gap = [[np.mean([_size(m["by_band"][c][b]["residual_m"]) for m in maps]) for b in bands] for c in bchan]
    fig = MplFigure(figsize=(11, 2.3 + 0.35 * len(logs) + 1.2 * ((len(panels) + 1) > 2)))
    axes = fig.subplots(1, len(panels) + 1, gridspec_kw={"width_ratios": [len(p[1]) + 1 for p in panels]
                                                         + [len(bands) + 1]})
    im = None
    for ax, (title, cols, ratio, gap) in zip(axes, panels):
        im = _heat(ax, ratio, logs, cols, title, [[f"{g:.2f}" for g in row] for row in gap])
    _heat(axes[-1], band_ratio, bchan, [b.replace("_", " ") for b in bands], "by band (mean of the logs)",
          [[f"{g:.2f}" for g in row] for row in band_gap])
    for ax in axes[1:len(panels)]:
        ax.set_yticklabels([])
    # the band panel's rows are channels, not logs: labelled on its right, clear of the panel before it
    axes[-1].yaxis.tick_right()
    cb = fig.colorbar(im, ax=list(axes), orientation="horizontal", fraction=0.06, pad=0.35, aspect=60)
    cb.set_label("gap / noise floor (-); cells: gap (m)", fontsize=8)
    return Figure(figure_png(fig), f"{esc(name)}: where the baseline's gap lies. Colour: gap over the log's own "
                                   f"noise floor (below {NOISE_FACTOR:g}: noise); numbers: the gap in metres; "
                                   "blank: nothing compared there (components the model does not reproduce "
                                   "are left out).",
                  f"diagnosis-{name.replace('/', '-')}-where")


def _cross_figure(name: str, log: str, before: dict, after: dict | None, effect: str):
    """One log's channel x phase and station x band tables as heat maps of gap
    over noise floor, baseline and (when there is one) best explanation side
    by side; a cell reads its gap (m) over its ratio to the floor."""
    from matplotlib.figure import Figure as MplFigure
    tables = [("channel x phase", "channel_phase", False), ("station x band (hose)", "station_band", True)]
    tables = [t for t in tables if before.get(t[1])]
    states = [("baseline", before)] + ([(f"with {effect}", after)] if after else [])
    panels = [(f"{title}, {state}", m[key], flip) for title, key, flip in tables for state, m in states]
    ratios = [np.array([[_over(g, f) for g, f in zip(gr, fr)]
                        for gr, fr in zip(p["gap_m"], p["floor_m"])], float) for _, p, _ in panels]
    vmax = _scale_top(*ratios)
    fig = MplFigure(figsize=(11, 3.4 * len(tables)))
    # room between the rows for the upper maps' column labels
    axes = fig.subplots(len(tables), len(states), squeeze=False, gridspec_kw={"hspace": 0.7}).ravel()
    im = None
    for ax, (title, p, flip), r in zip(axes, panels, ratios):
        gaps = np.array([[np.nan if g is None else g for g in row] for row in p["gap_m"]], float)
        rows, cols = p["rows"], p["cols"]
        if flip:    # a long station axis reads along x
            r, gaps, rows, cols = r.T, gaps.T, cols, rows
        text = [[f"{g:.2f}\n{q:.0f}×" for g, q in zip(gr, qr)] for gr, qr in zip(gaps, r)]
        im = _heat(ax, r, rows, cols, title, text, vmax)
        if flip:
            ax.set_xlabel("station along the hose (m)", fontsize=8)
    # the pad is a share of one row's height: under the lowest row's tick labels
    cb = fig.colorbar(im, ax=list(axes), orientation="horizontal", fraction=0.05, pad=0.25 / len(tables) + 0.03,
                      aspect=60)
    cb.set_label("gap / noise floor (-); cells: gap (m) over gap / floor", fontsize=8)
    return Figure(figure_png(fig), f"{esc(name)}, {esc(log)}: the gap by channel and test phase"
                  + (" and along the hose by band" if len(tables) > 1 else "")
                  + (f", before and after {esc(effect)}" if after else " (the baseline is ranked first)")
                  + f". Colour: the gap over the log's own noise floor (below {NOISE_FACTOR:g}: noise); "
                    "a blank cell has no component, or only ones the model does not reproduce (left out).",
                  f"diagnosis-{name.replace('/', '-')}-{log}-cross")


def _overlay_figure(name: str, log: str, before: dict, after: dict | None, effect: str):
    """The log, the baseline and the best explanation overlaid: the drogue
    channel with the largest baseline gap over time, or a trail's hose mean shape."""
    from matplotlib.figure import Figure as MplFigure
    sb = before["series"]
    fig = MplFigure(figsize=(11, 3.0))
    ax = fig.subplots()
    styles = [("log", "k", "-", 1.6), ("baseline", "tab:red", "--", 1.3), (f"with {effect}", "tab:blue", "-.", 1.3)]
    series = [sb] + ([after["series"]] if after else [])
    if sb["kind"] == "hose shape":
        traces = [(sb["log"]["x_m"], sb["log"]["z_m"])] + [(s["sim"]["x_m"], s["sim"]["z_m"]) for s in series]
        ax.set_xlabel("x along the trail (m)")
        ax.set_ylabel("hose mean shape z (m)")
        what = "the hose's mean shape"
    else:
        gaps = {c: before["by_channel"][f"drogue {c}"]["gap_m"] for c in "xyz"}
        c = max(gaps, key=gaps.get)
        traces = [(sb["t_s"], sb["log"][c])] + [(s["t_s"], s["sim"][c]) for s in series]
        ax.set_xlabel("time (s)")
        ax.set_ylabel(f"drogue {c} (m)")
        what = f"the drogue's {c} (its largest gap), means over {len(sb['t_s'])} equal time bins"
    for (lab, col, ls, lw), (x, y) in zip(styles, traces):
        ax.plot(x, np.array(y, float), color=col, ls=ls, lw=lw, marker="o" if lab == "log" and len(x) < 60 else None,
                ms=3, label=lab)
    ax.grid(alpha=0.3)
    ax.set_title(log, fontsize=9)
    legend_below(fig, ax, ncol=3)
    fig.tight_layout()
    return Figure(figure_png(fig), f"{esc(name)}, {esc(log)}: {what}: the log (solid), the baseline (dashed)"
                  + (f" and the best explanation, {esc(effect)} with its parameters fitted on all the logs "
                     "(dash-dot)" if after else "") + ".",
                  f"diagnosis-{name.replace('/', '-')}-{log}-overlay")


def _per_log_figures(name: str, d: dict) -> list:
    """Per log, the heat maps and the overlay; a note instead when the
    diagnosis.json predates their tables and series."""
    after_all = d.get("gap_after_best") or {}
    effect = d["ranking"][0]["effect"] if d["ranking"] else "none"
    out = []
    for log, before in d["gap"].items():
        after = after_all.get(log)
        if "channel_phase" not in before or "series" not in before:
            return [Para("This diagnosis.json predates the channel x phase and station x band tables and the "
                         "overlay series of the where-map, so those figures are left out; run "
                         "workbench diagnose again to draw them.", "note")]
        out += [_cross_figure(name, log, before, after, effect), _overlay_figure(name, log, before, after, effect)]
    return out


def _ranking_figure(name: str, d: dict):
    """Held-out gap per candidate against the baseline gap and the noise
    floor, and the calibrated parameters with ±1 standard error."""
    from matplotlib.figure import Figure as MplFigure
    rank = d["ranking"]
    fig = MplFigure(figsize=(11, 0.9 + 0.32 * max(len(rank), 4)))
    ax1, ax2 = fig.subplots(1, 2)
    y = np.arange(len(rank))[::-1]
    ax1.barh(y, [c["gap_after_heldout"] or np.nan for c in rank], color="tab:blue", label="held out")
    ax1.plot([c["gap_after_train"] for c in rank], y, "k|", ms=10, label="training")
    ax1.axvline(d["gap_before"], color="tab:red", ls="--", lw=1, label="baseline gap")
    ax1.axvline(NOISE_FACTOR * d["noise_floor"], color="0.4", ls=":", lw=1,
                label=f"{NOISE_FACTOR:g} × noise floor")
    ax1.set_xscale("log")
    ax1.set_yticks(y, [c["effect"] for c in rank], fontsize=7)
    ax1.set_xlabel("gap after calibration (m)")
    labels, vals, errs = [], [], []
    for c in rank[:5]:
        p, s = c["params"], c["param_stderr"]
        if len(c["effects"]) == 1:
            p, s = {c["effect"]: p}, {c["effect"]: s}
        for e, ps in p.items():
            for k, v in ps.items():
                labels.append(f"{c['effect']}: {e}.{k}")
                vals.append(v)
                errs.append(s[e][k])
    yy = np.arange(len(labels))[::-1]
    ax2.errorbar(vals, yy, xerr=errs, fmt="o", color="tab:green", capsize=3, label="value ± 1 s.e.")
    ax2.set_yticks(yy, labels, fontsize=7)
    ax2.set_xlabel("calibrated parameter (the effect's own scale, -)")
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3, axis="x")
    legend_below(fig, [ax1, ax2], ncol=5)
    fig.tight_layout()
    return Figure(figure_png(fig), f"{esc(name)}: gap after each candidate explanation (held out: bars; training: "
                                   "ticks) and the top five candidates' calibrated parameters with ±1 standard "
                                   "error (bars smaller than the marker are not drawn wider).",
                  f"diagnosis-{name.replace('/', '-')}-ranking")


def _before_after_figure(name: str, d: dict):
    """Per log and channel: the gap of the baseline and with the best explanation."""
    from matplotlib.figure import Figure as MplFigure
    after = d.get("gap_after_best") or {}
    if not after:
        return None
    logs = list(d["gap"])
    chans = list(d["gap"][logs[0]]["by_channel"])
    fig = MplFigure(figsize=(11, 2.8))
    axes = fig.subplots(1, len(logs), sharey=True, squeeze=False)[0]
    x = np.arange(len(chans))
    for ax, log in zip(axes, logs):
        b = [d["gap"][log]["by_channel"][c]["gap_m"] for c in chans]
        a = [after[log]["by_channel"][c]["gap_m"] for c in chans]
        fl = [after[log]["by_channel"][c]["floor_m"] for c in chans]
        ax.bar(x - 0.2, b, 0.4, color="tab:red", label="baseline")
        ax.bar(x + 0.2, a, 0.4, color="tab:blue", label=f"with {d['ranking'][0]['effect']}")
        ax.plot(x, [NOISE_FACTOR * f for f in fl], "k_", ms=14, label=f"{NOISE_FACTOR:g} × noise floor")
        ax.set_xticks(x, chans, fontsize=7, rotation=20)
        ax.set_title(log, fontsize=9)
        ax.set_yscale("log")
        ax.grid(alpha=0.3, axis="y")
    axes[0].set_ylabel("gap (m)")
    legend_below(fig, axes[0], ncol=3)
    fig.tight_layout()
    return Figure(figure_png(fig), f"{esc(name)}: the gap per channel before and after the best explanation, "
                                   "per log (from the where-maps).",
                  f"diagnosis-{name.replace('/', '-')}-before-after")


def _confusion_figure(st: dict):
    """The blind selftest: the withheld effect against the effect ranked first."""
    from matplotlib.figure import Figure as MplFigure
    rows = st.get("rows") or []
    if not rows:
        return None
    truth = sorted({r["effect"] for r in rows})
    top = truth + sorted({r["top"] for r in rows} - set(truth))
    m = np.zeros((len(truth), len(top)), int)
    for r in rows:
        m[truth.index(r["effect"]), top.index(r["top"])] += 1
    fig = MplFigure(figsize=(8, 0.9 + 0.45 * len(truth)))
    ax = fig.subplots()
    ax.imshow(m, cmap="Blues", aspect="auto")
    for i in range(m.shape[0]):
        for j in range(m.shape[1]):
            if m[i, j]:
                ax.text(j, i, str(m[i, j]), ha="center", va="center", fontsize=8,
                        color="white" if m[i, j] > m.max() / 2 else "black")
    ax.set_xticks(range(len(top)), top, rotation=30, ha="right", fontsize=7)
    ax.set_yticks(range(len(truth)), truth, fontsize=7)
    ax.set_xlabel("effect the diagnosis ranked first")
    ax.set_ylabel("effect withheld in the log")
    fig.tight_layout()
    return Figure(figure_png(fig), f"Blind selftest: confusion matrix of {st['n']} generated logs (counts; the "
                                   "diagonal is a right answer).", "diagnosis-selftest-confusion")


def _effect_cell(c: dict) -> Cell:
    """A ranked candidate's name in the ranking table, with its shares, and
    what is implausible or a calibration within a data sheet's tolerance."""
    return Cell(esc(c["effect"]) + _shares_text(c)
                + (f" (implausible: {esc(c['implausible'])})" if c.get("implausible") else "")
                + (f" (within data-sheet tolerance: {esc(', '.join(c['calibrations']))})"
                   if c.get("calibrations") else ""))


def report_blocks(diag: dict, title: str = "Sim-to-real gap diagnosis") -> list:
    """The diagnosis as report blocks (a level-1 heading first), from the
    diagnosis.json content (`Diagnosis.to_json()`, or the file read back)."""
    out = [Heading(1, esc(title), "diagnosis"),
           Para(f"Gap per family (m, defined per family), before and after each candidate explanation, "
                f"calibrated on training data and scored held out. Forward selection adds, one at a time and up "
                f"to {diag.get('max_effects', '?')}, the effect that most cuts the held-out gap while what it "
                f"explains of the gap (in quadrature) beats {NOISE_FACTOR:g}× the noise floor and its cut beats "
                f"{PARAM_PENALTY:g} × its new parameters × the gap left (once turbulence's random motion is real, "
                f"the noise includes what it explains by chance along the addition's own pattern, from an "
                f"ensemble of seeded runs, at Šidák's quantile for the best of the additions tried). Once it "
                f"stops, the selected set is revised: a form parameter the hardware lets the logs tell is "
                f"refined when it earns its place by the same rule, an event the later ones made redundant is "
                f"removed, and an event is traded for a calibration within its data sheet's tolerance where the "
                f"held-out gap stays within the noise floor of the selected set's (fewer events named). The "
                f"selected set ranks first, then the other "
                f"candidates fitted on the way by held-out gap × (1 + {PARAM_PENALTY:g} per parameter). A gap under "
                f"{NOISE_FACTOR:g}× its noise floor is noise. Probabilities: Akaike weights of the held-out "
                f"residuals, each candidate against the best over the components in which the two differ, the "
                f"evidence per m² at most what the selection's own test allows; a set "
                f"with turbulence takes, of its deterministic set's weight, the probability that the random motion "
                f"is real and at least light, and one with the reel lag the probability that the reel's take-up "
                f"departs from the program's reel. Scheduler: {esc(diag.get('scheduler'))}.")]
    for name, d in diag["families"].items():
        prob = any("probability" in c for c in d["ranking"])
        out += [Heading(2, esc(name), f"diagnosis-{anchor(name)}"),
                Para(f"Logs {esc(', '.join(d['logs']))}. {esc(d['gap_definition'])}. Baseline gap "
                     f"{fmt(d['gap_before'])} m against a noise floor of {fmt(d['noise_floor'])} m "
                     f"({'real' if d['gap_real'] else 'within noise'}); held out by {esc(d['held_out_scheme'])}; "
                     f"{d['n_elements']} elements; {d['wall_s']:.0f} s.")]
        rows = [[i + 1, _effect_cell(c), Cell(_params_text(c), "small"), c["gap_before"],
                 c["gap_after_train"], c["gap_after_heldout"],
                 None if c.get("shrink_heldout") is None else 100 * c["shrink_heldout"]]
                + ([c.get("probability")] if prob else []) for i, c in enumerate(d["ranking"])]
        out.append(Table(["#", "effect", "parameters (± 1 s.e.)", "gap before (m)", "after, training (m)",
                          "after, held out (m)", "held-out shrink (%)"] + (["probability"] if prob else []),
                         rows, [4, 20, 30, 10, 10, 10, 10] + ([8] if prob else []), title="Ranking",
                         row_class="ranking-row"))
        out.append(_ranking_figure(name, d))
        out += _selection_blocks(d)
        if d.get("failed"):
            out.append(Para("Failed, not ranked: " + "; ".join(f"{esc(c['effect'])} ({esc(c['message'])})"
                                                             for c in d["failed"]) + "."))
        out += _reel_blocks(d)
        out.append(Para(f"Remaining after the best: {fmt(d['remaining_unexplained']['gap_m'])} m, of which "
                        f"{fmt(d['remaining_unexplained']['above_noise_m'])} m above the noise floor."))
        out += _remainder_blocks(d)
        out.append(Table(["effect", "screen share", "or why not calibrated"],
                         [[Cell(esc(k)), v, Cell("–")] for k, v in d["screen"].items()]
                         + [[Cell(esc(k)), None, Cell(esc(v), "small")] for k, v in d["not_applicable"].items()],
                         [20, 12, 68], title="Screen: the share of the residual each effect's sensitivities span"))
        if d.get("not_separable"):
            out.append(Para(f"Not separable on these logs (sensitivity patterns parallel: noise-weighted "
                            f"principal-angle cosine at least {PARALLEL_COS:g}): "
                            + ", ".join(f"{esc(' and '.join(p['effects']))} ({p['cosine']:.3f})"
                                        for p in d["not_separable"]) + "."))
        out.append(_where_figure(name, d))
        ba = _before_after_figure(name, d)
        if ba is not None:
            out.append(ba)
        out += _per_log_figures(name, d)
    if diag.get("findings"):
        out += [Heading(2, "Findings of the diagnosis", "diagnosis-findings"),
                Table(["finding"], [[Cell(esc(s))] for s in diag["findings"]], [100])]
    if diag.get("selftest"):
        s = diag["selftest"]
        out += [Heading(2, "Proof on withheld effects", "diagnosis-selftest"),
                Para(f"{s['n']} generated logs (the solver with one library effect at random parameters, light "
                     f"turbulence, sensor noise and dropouts; {s.get('n_elements_truth', '?')} elements against the "
                     f"diagnosis's {s.get('n_elements_diagnosis', '?')}), effect withheld: right effect first in "
                     f"{100 * s['top1']:.0f} %, median held-out shrink {100 * s['median_shrink']:.0f} % (at least "
                     f"70 % in {100 * s.get('share_shrink_ge_70pct', float('nan')):.0f} % of the logs); "
                     f"{s['wall_s']:.0f} s."),
                Table(["kind", "logs", "right effect first (%)", "median held-out shrink (%)"],
                      [[Cell(esc(k)), v["n"], 100 * v["top1"], 100 * v["median_shrink"]]
                       for k, v in s.get("by_kind", {}).items()], [40, 20, 20, 20])]
        cm = _confusion_figure(s)
        if cm is not None:
            out.append(cm)
    return out


def diagnosis_provenance(diag: dict, prov: dict) -> list:
    """The inputs (log files with their SHA-256) and the code of a diagnosis."""
    deps = ", ".join(f"{esc(k)} {esc(v or 'not installed')}" for k, v in prov["dependencies"].items())
    rows = [[Cell(esc(p)), Cell(esc(file_sha256(ROOT / p)) if (ROOT / p).is_file() else "–", "small")]
            for p in diag.get("logs", [])]
    return [Heading(1, "Provenance", "provenance"),
            Para(f"Rendered with code {esc(prov['code_version'])} "
                 f"({'uncommitted changes in the tree' if prov['dirty'] else 'clean tree'}); Python "
                 f"{esc(prov['python'])}; {deps}."),
            Table(["log file", "SHA-256"], rows, [40, 60], title="Logs diagnosed")]
