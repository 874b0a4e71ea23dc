"""Plots of a `SimulationResult` (matplotlib is imported only here, and only when asked)."""
from __future__ import annotations

import numpy as np


def plot_result(result, kind: str = "summary", ax=None, n_shapes: int = 6):
    """'shape': side view (x down, z up) of hose shapes at evenly spaced times;
    'end': free-end x and z over time; 'summary': both plus the tow tension.
    Returns the matplotlib Figure."""
    import matplotlib
    if matplotlib.get_backend().lower() not in ("agg", "pdf", "svg") and ax is None:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kinds = ("summary", "shape", "end")
    if kind not in kinds:
        raise ValueError(f"plot kind {kind!r} is not one of {', '.join(kinds)}")
    if kind == "summary":
        fig, axes = plt.subplots(3, 1, figsize=(8, 9))
        _shape(result, axes[0], n_shapes)
        _end(result, axes[1])
        axes[2].plot(result.t, np.linalg.norm(result.tow_force, axis=1))
        axes[2].set_xlabel("t (s)")
        axes[2].set_ylabel("tow-point force (N)")
        fig.tight_layout()
        return fig
    if ax is None:
        fig, ax = plt.subplots(figsize=(8, 4))
    else:
        fig = ax.figure
    if kind == "shape":
        _shape(result, ax, n_shapes)
    else:
        _end(result, ax)
    return fig


def _shape(result, ax, n_shapes):
    idx = np.linspace(0, len(result.t) - 1, min(n_shapes, len(result.t))).astype(int)
    for k in idx:
        p = result.hose_points(k)
        ax.plot(p[:, 0], p[:, 2], label=f"t={result.t[k]:.2f} s")
        if result.drogue_xyz is not None:
            ax.plot(result.drogue_xyz[k, 0], result.drogue_xyz[k, 2], "o", color=ax.lines[-1].get_color())
    ax.set_xlabel("x aft of tow point (m)")
    ax.set_ylabel("z (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=7)


def _end(result, ax):
    end = result.end_xyz
    ax.plot(result.t, end[:, 0] - end[0, 0], label="x - x(0)")
    ax.plot(result.t, end[:, 2] - end[0, 2], label="z - z(0)")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("free-end displacement (m)")
    ax.legend()
