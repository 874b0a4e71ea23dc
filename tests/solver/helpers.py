"""Shared builders for the solver tests."""
import numpy as np

from solver.state import State


def straight_state(n, length, direction=(1.0, 0.0, 0.0), extra=None):
    """A straight chain of n equal elements at rest from the origin."""
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    l = length / n
    pos = np.outer(np.arange(n + 1) * l, d)
    if extra is not None:
        pos = np.vstack([pos, pos[-1] + np.asarray(extra, dtype=float)])
    return State(0.0, pos, np.zeros_like(pos), np.full(n, l), length)


def crossings_frequency(t, y):
    """Frequency from upward mean crossings, linearly interpolated."""
    z = y - y.mean()
    s = np.where((z[:-1] < 0) & (z[1:] >= 0))[0]
    tc = t[s] - z[s] * (t[s + 1] - t[s]) / (z[s + 1] - z[s])
    return (len(tc) - 1) / (tc[-1] - tc[0])
