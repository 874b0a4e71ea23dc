"""Report figures: the paper's figures reproduced with our data, simulation over
log. Each is a `document.Figure` (PNG bytes and a caption) that the HTML embeds
and the PDF scales to its page.

Styling rules every figure follows: axes labelled with units; the legend below
the axes (never over the data); a gate's tolerance drawn once; each model
variant with its own colour *and* line style, and a caption note where two
variants' curves coincide (so a hidden line is still accounted for).
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from flighttest import read_record  # noqa: E402
from flighttest.residual import engagement_moments  # noqa: E402
from workbench.outputs import safe_name  # noqa: E402
from workbench.report.document import Figure, esc, figure_png, legend_below  # noqa: E402

COLORS = ["tab:blue", "tab:red", "tab:green", "tab:purple", "tab:orange"]
LINESTYLES = ["-", "--", "-.", ":", (0, (5, 1, 1, 1))]
COINCIDE_M = 0.01   # curves closer than this everywhere are reported as coinciding (1 cm: below the tracker noise)


def _style(i: int) -> dict:
    return {"color": COLORS[i % len(COLORS)], "ls": LINESTYLES[i % len(LINESTYLES)]}


def _block(fig, name: str, caption: str) -> Figure:
    fig.tight_layout()
    return Figure(figure_png(fig), caption, name)


def _variant_label(case, vid):
    for v in case["variants"]:
        if v["id"] == vid:
            return v["label"] or vid
    return vid


def _runs_by_log(outcome):
    logs = {}
    for r in outcome.runs:
        logs.setdefault(r.log_id, []).append(r)
    return logs


def _coinciding(curves: dict[str, np.ndarray]) -> str:
    """A caption note naming variants whose curves (same sampling) lie within COINCIDE_M."""
    names = list(curves)
    pairs = [(a, b) for i, a in enumerate(names) for b in names[i + 1:]
             if curves[a].shape == curves[b].shape and np.nanmax(np.abs(curves[a] - curves[b])) < COINCIDE_M]
    if not pairs:
        return ""
    text = "; ".join(f"{esc(a)} and {esc(b)}" for a, b in pairs)
    return f" The curves of {text} coincide (within {COINCIDE_M * 100:g} cm): one lies over the other."


def _hose_lines(ax, case, runs, record_of, label_of=None, lw=1.2) -> None:
    """Each run's simulated hose (x, z) at its record `record_of(run)`, in its
    variant's style; `label_of(run, variant label)` words the legend entry."""
    for i, r in enumerate(runs):
        p = r.result.hose_points(record_of(r))
        lab = _variant_label(case, r.variant)
        ax.plot(p[:, 0], p[:, 2], lw=lw, **_style(i), label=label_of(r, lab) if label_of else lab)


def _shape_axes(x_axes, z_axes) -> None:
    """A hose shape's axes: x aft of the tow point, z up, in metres."""
    for ax in x_axes:
        ax.set_xlabel("x aft of the tow point (m)")
    for ax in z_axes:
        ax.set_ylabel("z (m, up)")


def doublet_figures(outcome) -> list[Figure]:
    """Fig. 11: drogue vertical response to the doublet, log and each variant,
    with the steady-height gate's tolerance drawn about the log."""
    out = []
    gate = next((g for g in outcome.gates if g.metric == "drogue_steady_z_error_m"), None)
    for log_id, runs in _runs_by_log(outcome).items():
        rec = read_record(runs[0].log_path)
        fixes = rec.tracker_fixes()
        fig, ax = plt.subplots(figsize=(8, 3.6))
        ax.plot(fixes.index.to_numpy(float), fixes["z_m"].to_numpy(float), ".", ms=2, color="k",
                label="flight (optical tracker)")
        zs = runs[0].metrics.get("drogue_steady_z_m_log")
        if gate is not None and zs is not None:
            ax.axhspan(zs - gate.threshold, zs + gate.threshold, color="0.88",
                       label=f"steady-height gate ({gate.variant}): flight ± {gate.threshold:g} m")
        curves = {}
        for i, r in enumerate(runs):
            ax.plot(r.result.t, r.result.end_xyz[:, 2], lw=1.3, **_style(i),
                    label=_variant_label(outcome.case, r.variant))
            curves[r.variant] = r.result.end_xyz[:, 2]
        ax.set_xlabel("time (s)")
        ax.set_ylabel("drogue z (m, up from the tow point)")
        ax.grid(alpha=0.3)
        legend_below(fig, ax, ncol=2)
        out.append(_block(fig, f"{outcome.case.id}-{log_id}-drogue-z",
                          f"{esc(log_id)}: drogue height through the tanker pitch doublet, flight against each "
                          f"model variant (paper Fig. 11).{_coinciding(curves)}"))
    return out


def trail_figures(outcome) -> list[Figure]:
    """Fig. 13-15: steady trail, video points against each variant's hose."""
    out = []
    gate = next((g for g in outcome.gates if g.metric == "trail_shape_rms_error_m"), None)
    for log_id, runs in _runs_by_log(outcome).items():
        rec = read_record(runs[0].log_path)
        hose = rec.topic("/video/hose")
        fig, ax = plt.subplots(figsize=(8, 3.6))
        ax.plot(hose["x_m"], hose["z_m"], ".", ms=2, color="0.45", label="flight (video hose points)")
        gated = [r for r in runs if gate is not None and r.variant == gate.variant]
        if gated:
            p = gated[0].result.hose_points(len(gated[0].result.t) - 1)
            ax.fill_between(p[:, 0], p[:, 2] - gate.threshold, p[:, 2] + gate.threshold, color="0.9",
                            label=f"shape gate: {gate.variant} ± {gate.threshold:g} m (RMS)")
        def with_rms(r, lab):
            rms = r.metrics.get("trail_shape_rms_error_m")
            return f"{lab} (shape RMS {rms:.2f} m)" if rms is not None else lab
        _hose_lines(ax, outcome.case, runs, lambda r: len(r.result.t) - 1, with_rms, lw=1.4)
        _shape_axes([ax], [ax])
        ax.grid(alpha=0.3)
        legend_below(fig, ax, ncol=2)
        out.append(_block(fig, f"{outcome.case.id}-{log_id}-trail",
                          f"{esc(log_id)}: steady trail, hose points from the chase video against each model "
                          "variant's static hose (paper Fig. 13-15)."))
    return out


def engagement_figures(outcome) -> list[Figure]:
    """Fig. 17-19: reel length, drogue motion, shape error over time, probe
    load; then the hose at the six moments over the video points."""
    out = []
    case = outcome.case
    for log_id, runs in _runs_by_log(outcome).items():
        rec = read_record(runs[0].log_path)
        moments = engagement_moments(rec)
        reel = rec.topic("/reel/hose_out")
        fixes = rec.tracker_fixes()
        fig, axes = plt.subplots(2, 2, figsize=(10, 6.4))
        ax = axes[0, 0]
        ax.plot(reel.index, reel["length_m"], color="k", lw=1.6, label="flight")
        for i, r in enumerate(runs):
            ax.plot(r.result.t, r.result.reel_length, lw=1.1, **_style(i), label=_variant_label(case, r.variant))
        ax.set_ylabel("hose out (m)")
        ax.set_title("reel payout (Fig. 17)", fontsize=9)
        ax = axes[0, 1]
        x0 = np.median(fixes["x_m"].to_numpy(float)[:30])
        z0 = np.median(fixes["z_m"].to_numpy(float)[:30])
        ax.plot(fixes.index, fixes["x_m"] - x0, ".", ms=2, color="k", label="flight drogue x")
        ax.plot(fixes.index, fixes["z_m"] - z0, ".", ms=2, color="0.6", label="flight drogue z")
        r = runs[0]
        e = r.result.end_xyz
        ax.plot(r.result.t, e[:, 0] - e[0, 0], color="tab:cyan", lw=1, label=f"model x ({r.variant})")
        ax.plot(r.result.t, e[:, 2] - e[0, 2], color="tab:brown", lw=1, ls="--", label=f"model z ({r.variant})")
        ax.set_ylabel("drogue displacement (m)")
        ax.set_title("drogue (Fig. 18)", fontsize=9)
        ax = axes[1, 0]
        for i, r in enumerate(runs):
            ts = np.array(r.metrics.get("shape_error_time_s") or [])
            es = np.array([np.nan if v is None else v for v in (r.metrics.get("shape_error_rms_m") or [])])
            ax.plot(ts, es, lw=1, **_style(i))
        for tm in moments.values():
            ax.axvline(tm, color="0.75", lw=0.7)
        for g in {(g.metric, g.threshold): g for g in outcome.gates
                  if g.metric == "shape_rms_error_engaged_m"}.values():
            ax.axhline(g.threshold, color="k", ls=(0, (2, 2)), lw=0.9,
                       label=f"gate: engaged shape RMS ≤ {g.threshold:g} m ({g.variant})")
        ax.set_ylabel("hose shape RMS error (m)")
        ax.set_title("shape error against the video (grey: the six moments)", fontsize=9)
        ax = axes[1, 1]
        for i, r in enumerate(runs):
            ax.plot(r.result.t, np.linalg.norm(r.result.probe_force, axis=1) / 1e3, lw=1, **_style(i))
        ax.set_ylabel("probe load (kN)")
        ax.set_title("load on the probe", fontsize=9)
        for ax in axes.ravel():
            ax.set_xlabel("time (s)")
            ax.grid(alpha=0.3)
        legend_below(fig, axes, ncol=3)
        out.append(_block(fig, f"{case.id}-{log_id}-engagement",
                          f"{esc(log_id)}: reel payout, drogue motion, hose shape error and probe load through "
                          "the engagement (paper Fig. 17-18)."))

        hose = rec.topic("/video/hose")
        times = np.unique(hose["t_s"].to_numpy(float))
        fig, axes = plt.subplots(3, 2, figsize=(10, 8), sharex=True, sharey=True)
        for ax, (name, tm) in zip(axes.ravel(), moments.items()):
            tf = times[np.argmin(np.abs(times - tm))]
            fr = hose[hose["t_s"] == tf]
            ax.plot(fr["x_m"], fr["z_m"], "o", ms=3, color="k", label="flight (video hose points)")
            _hose_lines(ax, case, runs, lambda r, tf=tf: int(np.argmin(np.abs(r.result.t - tf))))
            ax.set_title(f"{name.replace('_', ' ')} (t = {tf:.1f} s)", fontsize=9)
            ax.grid(alpha=0.3)
        _shape_axes(axes[-1, :], axes[:, 0])
        legend_below(fig, axes, ncol=3)
        out.append(_block(fig, f"{case.id}-{log_id}-progression",
                          f"{esc(log_id)}: the hose at the paper's six moments of the engagement, video points "
                          "against each model variant (paper Fig. 19)."))
    return out


def ringdown_figures(outcome) -> list[Figure]:
    """Paper Fig. 6 and 7 for the case's hose from the property document, the
    constants against element length, and Fig. 9: measured against simulated
    frequency squared and damping at each tested temperature."""
    from workbench.properties import report as pr
    from workbench.properties.store import read_properties
    doc = read_properties()
    hose = outcome.case["hardware"]["hose"]
    out = []
    captions = {"fig6-measured": "bench bending ring-downs: frequency squared and damping against temperature "
                                 "(paper Fig. 6)",
                "fig7-constants": "tuned element constants against temperature (paper Fig. 7)",
                "constants-vs-length": "tuned bending constants against element length"}
    for name, fn in (("fig6-measured", pr.figure_measured), ("fig7-constants", pr.figure_element_constants),
                     ("constants-vs-length", pr.figure_element_length)):
        out.append(_block(fn(doc, hose), f"{outcome.case.id}-{name}", f"{esc(hose)}: {captions[name]}."))
    bend = sorted((r for r in outcome.runs if r.metrics["test"] == "bending"),
                  key=lambda r: r.metrics["temperature_F"])
    if bend:
        n = bend[0].metrics["n_elements"]
        T = [r.metrics["temperature_F"] for r in bend]
        fig, axes = plt.subplots(1, 2, figsize=(9, 3.4))
        axes[0].plot(T, [r.metrics["frequency_measured_hz"] ** 2 for r in bend], "o", mfc="none", label="bench test")
        axes[0].plot(T, [r.metrics["frequency_simulated_hz"] ** 2 for r in bend], "x", label=f"{n}-element model")
        axes[0].set_ylabel("frequency squared (Hz²)")
        axes[1].plot(T, [r.metrics["damping_measured"] for r in bend], "o", mfc="none")
        axes[1].plot(T, [r.metrics["damping_simulated"] for r in bend], "x")
        axes[1].set_ylabel("damping ratio (-)")
        for ax in axes:
            ax.set_xlabel("hose temperature (°F)")
            ax.grid(alpha=0.3)
        legend_below(fig, axes, ncol=2)
        out.append(_block(fig, f"{outcome.case.id}-fig9",
                          f"{esc(hose)}: bending ring-downs, bench test against the {n}-element model with the "
                          "property table at each tested temperature (paper Fig. 9)."))
    return out


FIGURES = {"pitch_doublet": doublet_figures, "trail": trail_figures, "engagement": engagement_figures,
           "ringdown_bending": ringdown_figures, "ringdown_axial": ringdown_figures}


def case_figures(outcome) -> list[Figure]:
    fn = FIGURES.get(outcome.case.kind)
    if fn is None or not outcome.runs:
        return []
    return fn(outcome)


def save_pngs(figures: list[Figure], out_dir: Path) -> list[Path]:
    """The figures as PNG files too (for slides), beside the report."""
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for f in figures:
        # ids from case and log files name the figure: kept inside its folder
        p = out_dir / safe_name(f"{f.name}.png")
        p.write_bytes(f.png)
        paths.append(p)
    return paths
