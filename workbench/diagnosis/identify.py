"""Identifiability: which screened effects a family's logs cannot tell apart.

Two effects are not separable on a family's logs when their sensitivity
patterns there (the screen's columns: residual change per unit of each
parameter, every log's components stacked) span nearly the same directions:
the largest cosine of the principal angles between the two column spaces,
each component weighted by 1 / its noise floor (a component the log measures
well counts more), is at least `PARALLEL_COS`. A fit can then trade one
effect for the other at no cost in gap, and the ranking between them is the
noise's, not the physics'.
"""
from __future__ import annotations

import numpy as np

PARALLEL_COS = 0.95       # principal-angle cosine at or above which two patterns are not separable
FLOOR_CLIP_SHARE = 0.1    # a floor below this share of the RMS floor counts as that (no component weighs > 10x)
BASIS_TOL = 1e-2          # directions below this share of an effect's largest response are not its pattern


def noise_weights(floor) -> np.ndarray:
    """1 / each component's floor, floors clipped below at `FLOOR_CLIP_SHARE`
    of their RMS (a zero floor, e.g. a one-point bin, must not dominate)."""
    f = np.asarray(floor, float)
    ref = float(np.sqrt(np.mean(f ** 2))) if len(f) else 1.0
    return 1.0 / np.maximum(f, FLOOR_CLIP_SHARE * ref if ref > 0 else 1.0)


def basis(A, tol: float = BASIS_TOL) -> np.ndarray:
    """An orthonormal basis of A's column space: the left singular vectors
    whose singular value is at least `tol` times the largest (none for a zero A)."""
    A = np.asarray(A, float).reshape(len(A), -1)
    if not A.size or not np.any(A):
        return np.zeros((A.shape[0], 0))
    U, s, _ = np.linalg.svd(A, full_matrices=False)
    return U[:, s >= tol * s[0]]


def principal_cosines(A, B, tol: float = BASIS_TOL) -> np.ndarray:
    """Cosines of the principal angles between the column spaces of A and B,
    largest first (Bjorck and Golub: the singular values of Qa^T Qb)."""
    Qa, Qb = basis(A, tol), basis(B, tol)
    if not Qa.shape[1] or not Qb.shape[1]:
        return np.zeros(0)
    return np.clip(np.linalg.svd(Qa.T @ Qb, compute_uv=False), 0.0, 1.0)


def largest_cosine(A, B, w=None) -> float:
    """The largest principal-angle cosine of A's and B's column spaces, rows
    weighted by `w` (None: unweighted); 0 when either is empty."""
    A, B = np.asarray(A, float), np.asarray(B, float)
    if w is not None:
        A, B = A * np.asarray(w, float)[:, None], B * np.asarray(w, float)[:, None]
    c = principal_cosines(A, B)
    return float(c[0]) if len(c) else 0.0


def not_separable(columns: dict, floor, threshold: float = PARALLEL_COS) -> list[dict]:
    """Every pair of effects in `columns` ({effect: S}, rows the family's
    components) whose noise-weighted patterns are parallel: [{"effects": [a,
    b], "cosine": c}], the most parallel first."""
    w = noise_weights(floor)
    names = list(columns)
    out = []
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            c = largest_cosine(columns[a], columns[b], w)
            if c >= threshold:
                out.append({"effects": [a, b], "cosine": c})
    return sorted(out, key=lambda p: -p["cosine"])


def partners(d) -> list[tuple]:
    """The ranked candidates a family's top explanation cannot be told from:
    (candidate, cosine) for each single effect whose pattern is parallel to
    the top's (`d.not_separable`) and whose held-out gap exceeds the top's by
    no more than the noise floor."""
    top = d.ranking[0]
    if len(top.effects) != 1:
        return []
    out = []
    for pair in d.not_separable:
        if top.effects[0] not in pair["effects"]:
            continue
        other = next(e for e in pair["effects"] if e != top.effects[0])
        for c in d.ranking[1:]:
            if c.effects == [other] and c.gap_after_heldout - top.gap_after_heldout <= d.noise_floor:
                out.append((c, pair["cosine"]))
    return out
