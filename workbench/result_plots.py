"""Figures of validation and diagnosis results for notebooks (`CaseOutcome.plot`,
`Diagnosis.plot`). Made as matplotlib Figures without pyplot, so that they
neither need nor change a backend: Jupyter shows the returned Figure, a
script saves it with `fig.savefig`."""
from __future__ import annotations

import numpy as np
import pandas as pd


def _figure(rows: int, height: float):
    from matplotlib.figure import Figure
    fig = Figure(figsize=(8, height), layout="constrained")
    return fig, fig.subplots(rows, 1, squeeze=False)[:, 0]


def runs_figure(runs: pd.DataFrame, metric: str, thresholds: list[tuple[str, float]], title: str):
    """`metric` of every run as a bar (variant / log), each threshold a dashed line."""
    fig, (ax,) = _figure(1, 1.5 + 0.35 * len(runs))
    labels = [f"{v} / {log}" + ("" if held else " (training)")
              for v, log, held in zip(runs["variant"], runs["log"], runs["held_out"])]
    values = runs[metric].to_numpy(float) if metric in runs else np.full(len(runs), np.nan)
    ax.barh(np.arange(len(runs)), values, color="tab:blue")
    ax.set_yticks(np.arange(len(runs)), labels)
    ax.invert_yaxis()
    for i, (label, value) in enumerate(thresholds):
        ax.axvline(value, color="tab:red", ls="--", lw=1, label=label if i < 6 else None)
    if thresholds:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)   # outside the bars
    ax.set(xlabel=metric, title=title)
    ax.grid(True, axis="x", alpha=0.3)
    return fig


def diagnosis_figure(families: dict):
    """Per family: each candidate's held-out gap (m) against the baseline gap and the noise floor."""
    fig, axes = _figure(len(families), 0.5 + sum(1.2 + 0.3 * len(d.ranking) for d in families.values()))
    for ax, (name, d) in zip(axes, families.items()):
        y = np.arange(len(d.ranking))
        ax.barh(y, [c.gap_after_heldout for c in d.ranking], color="tab:green", label="held-out gap with it")
        ax.set_yticks(y, [c.effect for c in d.ranking])
        ax.invert_yaxis()
        ax.axvline(d.gap_before, color="k", ls="-", lw=1, label="gap before (baseline)")
        ax.axvline(d.noise_floor, color="tab:gray", ls=":", lw=1, label="noise floor")
        ax.set(xlabel="gap (m)", title=name)
        ax.grid(True, axis="x", alpha=0.3)
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    return fig
