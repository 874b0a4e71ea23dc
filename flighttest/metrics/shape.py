"""Hose shape: projection onto a polyline, shape error and mean shape.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from .sampling import as_float


@dataclass(frozen=True)
class ShapeError:
    normal_error_m: np.ndarray      # signed, + when the point lies above/left of the line
    station_m: np.ndarray           # arc length of the foot point along the simulated line
    inside: np.ndarray              # foot point strictly within the line (not an end clamp)
    rms_m: float
    max_abs_m: float
    bins: pd.DataFrame              # per arc-length station bin: n, mean, rms
    vertical_error_m: np.ndarray    # z_meas - z_sim(x_meas), NaN outside the simulated x-range
    vertical_rms_m: float
    vertical_max_abs_m: float


def project_onto_polyline(q: np.ndarray, P: np.ndarray):
    """Foot points of points q (n, 2) on the polyline P (m, 2): the signed normal
    distance (positive on the left of the line walked from its first point,
    i.e. above a hose trailing aft), the arc-length station of the foot, and
    whether the foot lies strictly inside the line (not clamped to an end).
    Zero-length segments are dropped. Returns (err, station, inside, P, s_nodes)
    with the cleaned polyline and its nodes' arc lengths."""
    P = np.asarray(P, float)
    d, seg_len = _segments(P)
    if np.any(seg_len == 0):
        P = P[np.concatenate([[True], seg_len > 0])]
        d, seg_len = _segments(P)
    s_nodes = _arc(seg_len)
    n = (len(q),)
    err, station, inside = _feet(q, np.broadcast_to(P, n + P.shape), np.broadcast_to(d, n + d.shape),
                                 np.broadcast_to(seg_len, n + seg_len.shape),
                                 np.broadcast_to(s_nodes, n + s_nodes.shape))
    return err, station, inside, P, s_nodes


def project_onto_polylines(q: np.ndarray, lines: list, which: np.ndarray, chunk: int = 20000):
    """`project_onto_polyline` of each point q[i] (n, 2) on its own polyline
    `lines[which[i]]` (each (m, 2)): (err, station, inside), the same values
    as point by point, in one array pass per line length (lines with a
    zero-length segment one by one): one projection per video frame cost an
    engagement's residual two thirds of its time. Each line's segments are
    measured once; `chunk` points at a time bound the temporary arrays."""
    q, which = np.asarray(q, float), np.asarray(which, int)
    err, station, inside = np.empty(len(q)), np.empty(len(q)), np.empty(len(q), bool)
    size = np.array([len(P) for P in lines], int)
    clean = np.zeros(len(lines), bool)
    for m in np.unique(size):
        ks = np.flatnonzero(size == m)
        L = np.stack([np.asarray(lines[k], float) for k in ks])
        d, seg_len = _segments(L)
        ok = np.all(seg_len > 0, axis=1)
        ks, L, d, seg_len = ks[ok], L[ok], d[ok], seg_len[ok]
        s_nodes = _arc(seg_len)
        clean[ks] = True
        slot = np.full(len(lines), -1)
        slot[ks] = np.arange(len(ks))
        at = np.flatnonzero(slot[which] >= 0)
        for a in range(0, len(at), chunk):
            i = at[a:a + chunk]
            li = slot[which[i]]
            err[i], station[i], inside[i] = _feet(q[i], L[li], d[li], seg_len[li], s_nodes[li])
    for k in np.unique(which[~clean[which]]):
        i = which == k
        err[i], station[i], inside[i], _, _ = project_onto_polyline(q[i], lines[k])
    return err, station, inside


def _segments(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The segment vectors and lengths of the polylines P (..., m, 2)."""
    d = np.diff(P, axis=-2)
    return d, np.hypot(d[..., 0], d[..., 1])


def _arc(seg_len: np.ndarray) -> np.ndarray:
    """Arc lengths of the nodes from their segments' lengths (..., m - 1)."""
    return np.concatenate([np.zeros(seg_len.shape[:-1] + (1,)), np.cumsum(seg_len, axis=-1)], axis=-1)


def _feet(q: np.ndarray, P: np.ndarray, d: np.ndarray, seg_len: np.ndarray, s_nodes: np.ndarray):
    """(err, station, inside) of each point q[i] on its polyline P[i] (n, m, 2),
    with its segments d[i], seg_len[i] (no zero length) and nodes' arc lengths
    s_nodes[i]."""
    r = q[:, None, :] - P[:, :-1, :]
    u = np.clip((r[..., 0] * d[..., 0] + r[..., 1] * d[..., 1]) / seg_len ** 2, 0.0, 1.0)
    foot = P[:, :-1, :] + u[..., None] * d
    dist = np.hypot(q[:, None, 0] - foot[..., 0], q[:, None, 1] - foot[..., 1])
    j = np.argmin(dist, axis=1)
    rows = np.arange(len(q))
    uj = u[rows, j]
    cross = d[rows, j, 0] * r[rows, j, 1] - d[rows, j, 1] * r[rows, j, 0]
    err = np.sign(cross) * dist[rows, j]
    station = s_nodes[rows, j] + uj * seg_len[rows, j]
    inside = ~(((j == 0) & (uj <= 0.0)) | ((j == d.shape[1] - 1) & (uj >= 1.0)))
    return err, station, inside


def shape_error(x_meas, z_meas, x_sim, z_sim, *, bin_m: float = 1.0) -> ShapeError:
    """Distance of measured hose points from a simulated centre line.

    Method: for each measured point the nearest point of the simulated
    polyline (segment by segment projection) gives the signed normal
    distance (positive on the left of the line walked from the tow point,
    i.e. above a hose trailing aft) and the arc-length station of the foot.
    Points whose nearest foot is an end of the line are not normal
    distances and are left out of the statistics (`inside` is False).
    RMS and max use the inside points; `bins` groups them by station.
    The vertical error compares z at equal downstream distance x, by linear
    interpolation of the simulated line (which must advance in x), only
    where x lies inside the simulated range.
    """
    q = np.column_stack([as_float(x_meas), as_float(z_meas)])
    q = q[np.all(np.isfinite(q), axis=1)]
    P = np.column_stack([as_float(x_sim), as_float(z_sim)])
    if len(P) < 2:
        raise ValueError("simulated line needs at least 2 points")
    err, station, inside, P, s_nodes = project_onto_polyline(q, P)
    e_in = err[inside]
    rms = float(np.sqrt(np.mean(e_in ** 2))) if len(e_in) else float("nan")
    mx = float(np.max(np.abs(e_in))) if len(e_in) else float("nan")
    edges = np.arange(0.0, s_nodes[-1] + bin_m, bin_m)
    idx = np.clip(np.digitize(station[inside], edges) - 1, 0, len(edges) - 2)
    bdf = pd.DataFrame({"bin": idx, "e": e_in})
    g = bdf.groupby("bin")["e"]
    bins = pd.DataFrame({"station_lo_m": edges[:-1], "station_hi_m": edges[1:]})
    bins["n"] = g.count().reindex(range(len(edges) - 1), fill_value=0).to_numpy()
    bins["mean_m"] = g.mean().reindex(range(len(edges) - 1)).to_numpy()
    bins["rms_m"] = np.sqrt((bdf.assign(e2=bdf["e"] ** 2).groupby("bin")["e2"].mean())
                            .reindex(range(len(edges) - 1))).to_numpy()
    xs, zs = P[:, 0], P[:, 1]
    if np.all(np.diff(xs) > 0):
        inx = (q[:, 0] >= xs[0]) & (q[:, 0] <= xs[-1])
        vert = np.full(len(q), np.nan)
        vert[inx] = q[inx, 1] - np.interp(q[inx, 0], xs, zs)
    else:
        vert = np.full(len(q), np.nan)
    vv = vert[np.isfinite(vert)]
    return ShapeError(
        normal_error_m=err, station_m=station, inside=inside, rms_m=rms, max_abs_m=mx, bins=bins,
        vertical_error_m=vert,
        vertical_rms_m=float(np.sqrt(np.mean(vv ** 2))) if len(vv) else float("nan"),
        vertical_max_abs_m=float(np.max(np.abs(vv))) if len(vv) else float("nan"))


def mean_shape(x, z, *, bin_m: float = 1.0, x_min: float | None = None,
               x_max: float | None = None) -> pd.DataFrame:
    """Mean shape of a cloud of (x, z) points binned along x.

    Returns per bin: x_m (mean x of the points in the bin), z_m (mean z),
    z_std_m, n.  Bins with no points are dropped.
    """
    x, z = as_float(x), as_float(z)
    ok = np.isfinite(x) & np.isfinite(z)
    x, z = x[ok], z[ok]
    lo = np.floor(x.min() / bin_m) * bin_m if x_min is None else x_min
    hi = x.max() if x_max is None else x_max
    edges = np.arange(lo, hi + bin_m, bin_m)
    idx = np.digitize(x, edges) - 1
    df = pd.DataFrame({"bin": idx, "x": x, "z": z})
    df = df[(df["bin"] >= 0) & (df["bin"] < len(edges) - 1)]
    g = df.groupby("bin")
    out = pd.DataFrame({"x_m": g["x"].mean(), "z_m": g["z"].mean(),
                        "z_std_m": g["z"].std(ddof=1), "n": g["z"].count()})
    return out.reset_index(drop=True)


# --------------------------------------------------------------------------
