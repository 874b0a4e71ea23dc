"""Report figures: the paper's figures reproduced with our data, simulation over log."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from flighttest import read_record  # noqa: E402
from workbench.outputs import safe_name  # noqa: E402
from flighttest.residual import engagement_moments  # noqa: E402

COLORS = ["tab:blue", "tab:red", "tab:green", "tab:purple", "tab:orange"]


def _save(fig, out_dir: Path, name: str) -> Path:
    # ids from case and log files name the figure: kept inside its folder
    path = Path(out_dir) / safe_name(name)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


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


def doublet_figures(outcome, out_dir: Path) -> list[Path]:
    """Fig. 11: drogue vertical response to the doublet, log and each variant,
    with the steady-height gate's tolerance drawn about the log."""
    paths = []
    tol = next((g.threshold for g in outcome.gates if g.metric == "drogue_steady_z_error_m"), None)
    for log_id, runs in _runs_by_log(outcome).items():
        rec = read_record(runs[0].log_path)
        fixes = rec.tracker_fixes()
        fig, ax = plt.subplots(figsize=(8, 3.6))
        t = fixes.index.to_numpy(float)
        z = fixes["z_m"].to_numpy(float)
        ax.plot(t, z, ".", ms=2, color="k", label="flight (ORS)")
        if tol is not None:
            zs = runs[0].metrics.get("drogue_steady_z_m_log")
            if zs is not None:
                ax.axhspan(zs - tol, zs + tol, color="0.85", label=f"steady-height gate +/-{tol:g} m")
        for i, r in enumerate(runs):
            ax.plot(r.result.t, r.result.end_xyz[:, 2], color=COLORS[i % 5], lw=1.2,
                    label=_variant_label(outcome.case, r.variant))
        ax.set_xlabel("t (s)")
        ax.set_ylabel("drogue z (m)")
        ax.set_title(f"{log_id}: drogue response to the pitch doublet")
        ax.legend(fontsize=7, loc="lower right")
        paths.append(_save(fig, out_dir, f"{outcome.case.id}-{log_id}-drogue-z.png"))
    return paths


def trail_figures(outcome, out_dir: Path) -> list[Path]:
    """Fig. 13-15: steady trail, video points against each variant's hose."""
    paths = []
    for log_id, runs in _runs_by_log(outcome).items():
        rec = read_record(runs[0].log_path)
        hose = rec.topic("/video/hose")
        fig, ax = plt.subplots(figsize=(8, 3.6))
        ax.plot(hose["x_m"], hose["z_m"], ".", ms=2, color="0.5", label="flight (video points)")
        gate = next((g for g in outcome.gates if g.metric == "trail_shape_rms_error_m"), None)
        gated = [r for r in runs if gate is not None and r.variant == gate.variant]
        if gated:
            p = gated[0].result.hose_points(len(gated[0].result.t) - 1)
            ax.fill_between(p[:, 0], p[:, 2] - gate.threshold, p[:, 2] + gate.threshold, color="0.88",
                            label=f"shape gate +/-{gate.threshold:g} m about {gate.variant}")
        for i, r in enumerate(runs):
            p = r.result.hose_points(len(r.result.t) - 1)
            rms = r.metrics.get("trail_shape_rms_error_m")
            ax.plot(p[:, 0], p[:, 2], color=COLORS[i % 5], lw=1.4,
                    label=f"{_variant_label(outcome.case, r.variant)} (RMS {rms:.2f} m)" if rms else r.variant)
        ax.set_xlabel("x aft of tow point (m)")
        ax.set_ylabel("z (m)")
        ax.set_title(f"{log_id}: steady trail")
        ax.legend(fontsize=7, loc="lower left")
        paths.append(_save(fig, out_dir, f"{outcome.case.id}-{log_id}-trail.png"))
    return paths


def engagement_figures(outcome, out_dir: Path) -> list[Path]:
    """Fig. 17-19: reel length, drogue motion, hose progression at the six
    moments drawn over the video points, shape error over time, probe load."""
    paths = []
    for log_id, runs in _runs_by_log(outcome).items():
        rec = read_record(runs[0].log_path)
        moments = engagement_moments(rec)
        reel = rec.topic("/reel/hose_out")
        fixes = rec.tracker_fixes()
        fig, axes = plt.subplots(2, 2, figsize=(10, 6))
        ax = axes[0, 0]
        ax.plot(reel.index, reel["length_m"], color="k", lw=1, label="flight")
        for i, r in enumerate(runs):
            ax.plot(r.result.t, r.result.reel_length, color=COLORS[i % 5], lw=1,
                    label=_variant_label(outcome.case, r.variant))
        ax.set_ylabel("hose out (m)")
        ax.set_title("reel (Fig. 17)")
        ax.legend(fontsize=7)
        ax = axes[0, 1]
        x0 = np.median(fixes["x_m"].to_numpy(float)[:30])
        z0 = np.median(fixes["z_m"].to_numpy(float)[:30])
        ax.plot(fixes.index, fixes["x_m"] - x0, ".", ms=2, color="k", label="flight x")
        ax.plot(fixes.index, fixes["z_m"] - z0, ".", ms=2, color="0.5", label="flight z")
        r = runs[0]
        e = r.result.end_xyz
        ax.plot(r.result.t, e[:, 0] - e[0, 0], color=COLORS[0], lw=1, label="model x")
        ax.plot(r.result.t, e[:, 2] - e[0, 2], color=COLORS[1], lw=1, label="model z")
        ax.set_ylabel("drogue change (m)")
        ax.set_title("drogue (Fig. 18)")
        ax.legend(fontsize=7)
        ax = axes[1, 0]
        for i, r in enumerate(runs):
            ts = np.array(r.metrics.get("shape_error_time_s") or [])
            es = np.array([np.nan if v is None else v for v in (r.metrics.get("shape_error_rms_m") or [])])
            ax.plot(ts, es, color=COLORS[i % 5], lw=1, label=_variant_label(outcome.case, r.variant))
        for name, tm in moments.items():
            ax.axvline(tm, color="0.7", lw=0.8)
        for g in outcome.gates:
            if g.metric == "shape_rms_error_engaged_m":
                ax.axhline(g.threshold, color="k", ls="--", lw=0.8, label=f"gate (RMS over contact) {g.threshold:g} m")
        ax.legend(fontsize=7)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("hose shape RMS error (m)")
        ax.set_title("shape error vs video")
        ax = axes[1, 1]
        for i, r in enumerate(runs):
            ax.plot(r.result.t, np.linalg.norm(r.result.probe_force, axis=1) / 1e3, color=COLORS[i % 5], lw=1,
                    label=_variant_label(outcome.case, r.variant))
        ax.set_xlabel("t (s)")
        ax.set_ylabel("probe load (kN)")
        ax.set_title("loads on the probe")
        paths.append(_save(fig, out_dir, f"{outcome.case.id}-{log_id}-engagement.png"))

        hose = rec.topic("/video/hose")
        times = np.unique(hose["t_s"].to_numpy(float))
        fig, axes = plt.subplots(3, 2, figsize=(10, 7), sharex=True, sharey=True)
        for ax, (name, tm) in zip(axes.ravel(), moments.items()):
            tf = times[np.argmin(np.abs(times - tm))]
            fr = hose[hose["t_s"] == tf]
            ax.plot(fr["x_m"], fr["z_m"], "o", ms=3, color="k", label="video")
            for i, r in enumerate(runs):
                k = int(np.argmin(np.abs(r.result.t - tf)))
                p = r.result.hose_points(k)
                ax.plot(p[:, 0], p[:, 2], color=COLORS[i % 5], lw=1.2,
                        label=_variant_label(outcome.case, r.variant))
            ax.set_title(f"{name.replace('_', ' ')} (t={tf:.1f} s)", fontsize=9)
        axes[0, 0].legend(fontsize=7)
        fig.suptitle(f"{log_id}: hose progression (Fig. 19)")
        paths.append(_save(fig, out_dir, f"{outcome.case.id}-{log_id}-progression.png"))
    return paths


def ringdown_figures(outcome, out_dir: Path) -> list[Path]:
    """Paper Fig. 6 and 7 for the case's hose from the property document, the
    constants against element length, and Fig. 9: measured against simulated
    frequency squared and damping at each tested temperature."""
    from workbench.properties import report as pr
    from workbench.properties.store import read_properties
    doc = read_properties()
    hose = outcome.case["hardware"]["hose"]
    paths = []
    for name, fn in (("fig6-measured", pr.figure_measured), ("fig7-constants", pr.figure_element_constants),
                     ("constants-vs-length", pr.figure_element_length)):
        fig = fn(doc, hose)
        path = out_dir / safe_name(f"{outcome.case.id}-{name}.png")
        fig.tight_layout()
        fig.savefig(path, dpi=80)
        paths.append(path)
    bend = sorted((r for r in outcome.runs if r.metrics["test"] == "bending"),
                  key=lambda r: r.metrics["temperature_F"])
    if bend:
        T = [r.metrics["temperature_F"] for r in bend]
        fig, axes = plt.subplots(1, 2, figsize=(9, 3.4))
        axes[0].plot(T, [r.metrics["frequency_measured_hz"] ** 2 for r in bend], "o", mfc="none", label="test")
        axes[0].plot(T, [r.metrics["frequency_simulated_hz"] ** 2 for r in bend], "x", label="8-element model")
        axes[0].set_ylabel("frequency squared (Hz^2)")
        axes[1].plot(T, [r.metrics["damping_measured"] for r in bend], "o", mfc="none", label="test")
        axes[1].plot(T, [r.metrics["damping_simulated"] for r in bend], "x", label="8-element model")
        axes[1].set_ylabel("damping ratio")
        for ax in axes:
            ax.set_xlabel("hose temperature (F)")
            ax.legend(fontsize=7)
        fig.suptitle(f"{hose}: verification (Fig. 9)")
        paths.append(_save(fig, out_dir, f"{outcome.case.id}-fig9.png"))
    return paths


FIGURES = {"pitch_doublet": doublet_figures, "trail": trail_figures, "engagement": engagement_figures,
           "ringdown_bending": ringdown_figures, "ringdown_axial": ringdown_figures}


def case_figures(outcome, out_dir: Path) -> list[Path]:
    fn = FIGURES.get(outcome.case.kind)
    if fn is None or not outcome.runs:
        return []
    return fn(outcome, out_dir)
