"""Wind fields: the air velocity in the tow-point frame at any point and time.

The tow-point frame moves with the tanker, so still air flows through it at the
true airspeed along +x (downstream). A wind field is a sum of components, each
a type code and its parameters packed into one float vector so the solver's
compiled inner loop evaluates it without returning to Python (and numba can
cache the compiled loop):

    params = [n_components, type, n_par, p_1 .. p_n_par, type, n_par, ...]

Effects of the environment (tanker wake, turbulence, bow wave, gusts) are
further component types evaluated in `wind_eval`; the hose code only ever calls
`wind_eval` and never knows which components are present.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit

UNIFORM = 0


@njit(cache=True)
def wind_eval(t, points, npoints, params, out):
    """Air velocity (m/s) at points[:npoints] at time t into out[:npoints]."""
    for i in range(npoints):
        out[i, 0] = 0.0
        out[i, 1] = 0.0
        out[i, 2] = 0.0
    ncomp = int(params[0])
    k = 1
    for _ in range(ncomp):
        kind = int(params[k])
        npar = int(params[k + 1])
        p = params[k + 2:k + 2 + npar]
        if kind == UNIFORM:
            for i in range(npoints):
                out[i, 0] += p[0]
                out[i, 1] += p[1]
                out[i, 2] += p[2]
        k += 2 + npar


@dataclass
class WindField:
    """A sum of wind components; `velocity(t, points)` is the Python-side view."""

    components: list = field(default_factory=list)   # [(type code, parameter array), ...]

    @property
    def params(self) -> np.ndarray:
        parts = [np.array([float(len(self.components))])]
        for kind, par in self.components:
            par = np.asarray(par, dtype=float)
            parts.append(np.array([float(kind), float(len(par))]))
            parts.append(par)
        return np.concatenate(parts)

    @property
    def mean_speed(self) -> float:
        """Magnitude of the uniform part, m/s (the free stream)."""
        v = np.zeros(3)
        for kind, par in self.components:
            if kind == UNIFORM:
                v += np.asarray(par, dtype=float)[:3]
        return float(np.linalg.norm(v))

    def velocity(self, t: float, points: np.ndarray) -> np.ndarray:
        pts = np.ascontiguousarray(np.atleast_2d(points), dtype=float)
        out = np.empty((len(pts), 3))
        wind_eval(float(t), pts, len(pts), self.params, out)
        return out

    def __call__(self, t: float, points: np.ndarray) -> np.ndarray:
        return self.velocity(t, points)

    def plus(self, kind: int, par) -> "WindField":
        return WindField(self.components + [(kind, np.asarray(par, dtype=float))])


def uniform(velocity) -> WindField:
    """The same air velocity (m/s, tow-point frame) everywhere, at all times."""
    v = np.asarray(velocity, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"uniform wind needs three finite components, got {velocity!r}")
    return WindField([(UNIFORM, v.copy())])


def freestream(true_airspeed: float) -> WindField:
    """Still air seen from a tanker flying at `true_airspeed` (m/s)."""
    return uniform([true_airspeed, 0.0, 0.0])
