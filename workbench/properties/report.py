"""Figures of the hose-property section of the report.

Everything is drawn from the property document (`workbench.properties.store`,
`read_properties`), so a report shows exactly what the committed file holds:

- `figure_measured`: paper Fig. 6, measured frequency squared and damping ratio
  against the measured temperature, with the cubic spline through the means;
- `figure_element_constants`: paper Fig. 7, the tuned element constants
  against temperature for each element length, with the table's splines;
- `figure_element_length`: constants x element length against element length
  (how the tuned constants follow from element length).

Paper Fig. 9 is drawn from the validation runs (`workbench.report.figures`).

Figures are `matplotlib.figure.Figure` objects (no pyplot state); the caller
saves or embeds them.
"""
from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter
from scipy.interpolate import CubicSpline

from solver.properties import PropertyTable
from workbench.report.document import legend_below


def _prov(doc: dict, hose: str) -> dict:
    if hose not in doc["hoses"]:
        raise ValueError(f"no hose {hose!r} in the property document "
                         f"(hoses: {', '.join(sorted(doc['hoses']))})")
    return doc["hoses"][hose]


def _measured(doc: dict, hose: str) -> dict:
    p = _prov(doc, hose)
    if p["status"] != "measured":
        raise ValueError(f"hose {hose} was never bench tested ({p['status']} from {p.get('derived_from')})")
    return p


def _spline_curve(x: np.ndarray, y: np.ndarray, n: int = 200) -> tuple[np.ndarray, np.ndarray]:
    xs = np.linspace(x[0], x[-1], n)
    return xs, CubicSpline(x, y, bc_type="not-a-knot")(xs)


def figure_measured(doc: dict, hose: str) -> Figure:
    """Paper Fig. 6: bending frequency squared (proportional to stiffness) and
    damping ratio against measured temperature: every record, the means with
    +-1 sample standard deviation, and the cubic spline through the means."""
    p = _measured(doc, hose)
    groups = p["bending_groups"]
    recs = [m for m in doc["measurements"] if m["hose"] == hose and m["test_kind"] == "ringdown_bending"]
    T = np.array([g["temperature_F"]["mean"] for g in groups])
    Tsd = np.array([g["temperature_F"]["std"] or 0.0 for g in groups])
    f = np.array([g["frequency_hz"]["mean"] for g in groups])
    fsd = np.array([g["frequency_hz"]["std"] or 0.0 for g in groups])
    z = np.array([g["damping_ratio"]["mean"] for g in groups])
    zsd = np.array([g["damping_ratio"]["std"] or 0.0 for g in groups])
    fig = Figure(figsize=(9, 4))
    ax1, ax2 = fig.subplots(1, 2)
    ax1.plot([m["temperature_F"] for m in recs], [m["frequency_hz"] ** 2 for m in recs], ".",
             color="0.6", label="records")
    ax1.errorbar(T, f ** 2, yerr=2 * f * fsd, xerr=Tsd, fmt="o", mfc="none", color="C0",
                 capsize=3, label="mean +- 1 std")
    ax1.plot(*_spline_curve(T, f ** 2), "C0-", lw=1, label="cubic spline")
    ax1.set_xlabel("measured temperature (F)")
    ax1.set_ylabel("first bending frequency squared (Hz^2)")
    ax2.plot([m["temperature_F"] for m in recs], [m["damping_ratio"] for m in recs], ".",
             color="0.6", label="records")
    ax2.errorbar(T, z, yerr=zsd, xerr=Tsd, fmt="o", mfc="none", color="C1", capsize=3,
                 label="mean +- 1 std")
    ax2.plot(*_spline_curve(T, z), "C1-", lw=1, label="cubic spline")
    ax2.set_xlabel("measured temperature (F)")
    ax2.set_ylabel("damping ratio (log decrement)")
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
    legend_below(fig, [ax1, ax2])
    rig = p["bench_rig"]["bending"]
    fig.suptitle(f"{hose}: bench bending ring-downs, {rig['section_length_m']} m cantilever")
    fig.tight_layout()
    return fig


def figure_element_constants(doc: dict, hose: str) -> Figure:
    """Paper Fig. 7: tuned k_b, c_b, k_a, c_a against temperature, one curve per
    element length (the table's spline), circles at the tuned points."""
    p = _prov(doc, hose)
    t = PropertyTable.from_dict(doc["tables"][hose])
    Ts = np.linspace(*t.temperature_range_F, 120)
    fig = Figure(figsize=(10, 7))
    axes = fig.subplots(2, 2).ravel()
    labels = {"k_b": "k_b (N m/rad)", "c_b": "c_b (N m s/rad)", "k_a": "k_a (N/m)", "c_a": "c_a (N s/m)"}
    idx = {"k_a": 0, "c_a": 1, "k_b": 2, "c_b": 3}
    cmap = [f"C{k % 10}" for k in range(len(t.element_lengths))]
    for ax, name in zip(axes, ("k_b", "c_b", "k_a", "c_a")):
        vals = getattr(t, name)
        for j, l in enumerate(t.element_lengths):
            curve = [t.constants(T, l)[idx[name]] for T in Ts]
            ax.plot(Ts, curve, "-", color=cmap[j], lw=1, label=f"l = {l:.3f} m")
            ax.plot(t.temperatures_F, vals[:, j], "o", mfc="none", color=cmap[j], ms=4)
        ax.set_yscale("log")
        ax.set_xlabel("temperature (F)")
        ax.set_ylabel(labels[name])
        ax.grid(alpha=0.3, which="both")
    legend_below(fig, axes[0], ncol=5)
    title = f"{hose}: element constants (circles: tuned; lines: cubic spline in temperature)"
    if p["status"] == "derived":
        title = (f"{hose} (DERIVED from {p['derived_from']} x {p['scale_factor']:.3f}, "
                 f"never bench tested): element constants")
    else:
        axes[2].set_title("axial: room-temperature value scaled like bending (assumption)", fontsize=8)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def figure_element_length(doc: dict, hose: str) -> Figure:
    """Constants against element length: k_b and c_b fall as 1/l (left, log-log,
    with a slope -1 guide), and their products with l (right) settle to the
    continuum EI and eta_b as the elements shorten; the rise at long elements is
    what the tuning adds to make a coarse chain ring at the measured frequency."""
    t = PropertyTable.from_dict(doc["tables"][hose])
    L = t.element_lengths
    fig = Figure(figsize=(10, 4))
    ax1, ax2 = fig.subplots(1, 2)
    for i, T in enumerate(t.temperatures_F):
        c = f"C{i % 10}"
        ax1.loglog(L, t.k_b[i], "o-", color=c, ms=3, label=f"{T:.1f} F")
        ax1.loglog(L, t.c_b[i], "s--", color=c, ms=3, mfc="none")
        ax2.plot(L, t.k_b[i] * L / (t.k_b[i, 0] * L[0]), "o-", color=c, ms=3, label=f"{T:.1f} F")
        ax2.plot(L, t.c_b[i] * L / (t.c_b[i, 0] * L[0]), "s--", color=c, ms=3, mfc="none")
    ref = t.k_b[0, 0] * L[0] / L
    ax1.loglog(L, ref, "k:", lw=1, label="slope -1")
    ax1.xaxis.set_minor_formatter(NullFormatter())
    ax1.set_xlabel("element length l (m)")
    ax1.set_ylabel("k_b (o, N m/rad), c_b (s, N m s/rad)")
    ax2.set_xlabel("element length l (m)")
    ax2.set_ylabel("k_b l (o), c_b l (s), over the shortest element's")
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3, which="both")
    legend_below(fig, ax1, ncol=5)
    fig.suptitle(f"{hose}: tuned bending constants against element length", fontsize=10)
    fig.tight_layout()
    return fig
