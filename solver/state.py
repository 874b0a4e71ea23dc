"""The instantaneous state of the hose, drogue and reel."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class State:
    """Node positions and velocities (tow-point frame, m and m/s), tow point first;
    with a drogue, the last row is the drogue's centre of mass. `rest` holds the
    rest lengths of the hose elements (element 0 at the reel exit)."""

    t: float
    pos: np.ndarray
    vel: np.ndarray
    rest: np.ndarray
    reel_length: float
    reel_speed: float = 0.0

    @property
    def n_hose(self) -> int:
        return len(self.rest)

    def copy(self) -> "State":
        return State(self.t, self.pos.copy(), self.vel.copy(), self.rest.copy(),
                     self.reel_length, self.reel_speed)
