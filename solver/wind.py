"""Wind fields: the air velocity in the tow-point frame at any point and time.

The tow-point frame moves with the tanker, so still air flows through it at the
true airspeed along +x (downstream). A wind field is the pair of a compiled
function and its parameter vector, so the solver's inner loop can call it
without returning to Python:

    kernel(t, points, npoints, params, out)   # writes out[:npoints, :3]

Effects of the environment (tanker wake, turbulence, bow wave, gusts) are wind
fields too; they plug in here without the hose code knowing of them.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit


@njit(cache=True)
def _uniform_kernel(t, points, npoints, params, out):
    for i in range(npoints):
        out[i, 0] = params[0]
        out[i, 1] = params[1]
        out[i, 2] = params[2]


@dataclass
class WindField:
    """A compiled wind field. `velocity(t, points)` is the Python-side view of it."""

    kernel: object
    params: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def velocity(self, t: float, points: np.ndarray) -> np.ndarray:
        pts = np.ascontiguousarray(np.atleast_2d(points), dtype=float)
        out = np.empty((len(pts), 3))
        self.kernel(float(t), pts, len(pts), self.params, out)
        return out

    def __call__(self, t: float, points: np.ndarray) -> np.ndarray:
        return self.velocity(t, points)


def uniform(velocity) -> WindField:
    """The same air velocity (m/s, tow-point frame) everywhere, at all times."""
    v = np.asarray(velocity, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"uniform wind needs three finite components, got {velocity!r}")
    return WindField(_uniform_kernel, v.copy())


def freestream(true_airspeed: float) -> WindField:
    """Still air seen from a tanker flying at `true_airspeed` (m/s)."""
    return uniform([true_airspeed, 0.0, 0.0])
