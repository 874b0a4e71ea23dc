"""The hose reel: how much hose is outside the pod, and how that changes.

Modes:
- `locked`: fixed length.
- `prescribed`: the length outside follows a table L(t) (e.g. from a log).
- `drum`: Eq. 12, I(L) phi'' = T_hose R(L) - T_reel, with L' = R phi'. Radius and
  inertia grow with the hose wound on the drum (see `solver.kernel.drum_radius_inertia`).
  Torque laws: `constant_torque` (T_reel fixed) and `constant_tension`
  (T_reel = T_set R, which holds the tension at the tanker at T_set in the steady
  state; with T_set left unset the model uses the initial steady tension, the
  paper's idealised reel).
  A drive hold-back (`drive_hold` > 0, the `reel_lag` effect) adds the force
  b (L' - L'_f) at the drum rim against the payout speed L', where L'_f is L'
  seen through the drive controller's dead time and first-order lag: the drive
  holds the drum at the speed it had until its controller responds, so the
  take-up follows a tension change late. The impedance b (1 - H) is passive for
  any dead time and lag (|H| <= 1), so it cannot destabilise the hose's stiff
  axial mode the way a delayed tension fed back to the drum does.

Hose paid out or taken in enters or leaves through the reel-exit element, whose
rest length changes; when it grows past 1.75 element lengths a node is inserted,
when it shrinks below 0.75 one is removed, both conserving mass and momentum.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

MODES = ("locked", "prescribed", "drum")
TORQUE_LAWS = ("constant_torque", "constant_tension")


@dataclass(frozen=True)
class ReelProperties:
    mode: str = "locked"
    payout_t: Optional[np.ndarray] = None       # s
    payout_length: Optional[np.ndarray] = None  # m of hose outside
    drum_radius_empty: float = 0.18
    drum_width: float = 0.6
    drum_inertia_empty: float = 4.0
    torque_law: str = "constant_tension"
    torque: Optional[float] = None              # N m for constant_torque
    tension: Optional[float] = None             # N for constant_tension; None: initial steady value
    drive_hold: float = 0.0                     # N s/m at the drum rim; 0: no hold-back
    drive_dead_time: float = 0.0                # s
    drive_lag: float = 0.0                      # s, first-order time constant

    def __post_init__(self):
        if self.mode not in MODES:
            raise ValueError(f"reel mode {self.mode!r} is not one of {', '.join(MODES)}")
        if self.torque_law not in TORQUE_LAWS:
            raise ValueError(f"reel torque_law {self.torque_law!r} is not one of {', '.join(TORQUE_LAWS)}")
        if self.mode == "prescribed":
            t = np.asarray(self.payout_t, dtype=float) if self.payout_t is not None else None
            L = np.asarray(self.payout_length, dtype=float) if self.payout_length is not None else None
            if t is None or L is None or t.shape != L.shape or t.ndim != 1 or len(t) < 2:
                raise ValueError("reel mode 'prescribed' needs payout_t and payout_length of equal length >= 2")
            if not (np.all(np.isfinite(t)) and np.all(np.isfinite(L))):
                raise ValueError("reel payout table holds non-finite values")
            if np.any(np.diff(t) <= 0):
                raise ValueError("reel payout_t must increase")
            if np.any(L <= 0):
                raise ValueError("reel payout_length must be positive")
        if self.mode == "drum":
            for name in ("drum_radius_empty", "drum_width", "drum_inertia_empty"):
                v = getattr(self, name)
                if not (math.isfinite(v) and v > 0):
                    raise ValueError(f"reel {name} must be positive, got {v!r}")
            if self.torque_law == "constant_torque" and self.torque is None:
                raise ValueError("reel torque_law 'constant_torque' needs a torque")
        for name in ("drive_hold", "drive_dead_time", "drive_lag"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"reel {name} must be a finite number >= 0, got {v!r}")
        if self.drive_hold > 0 and self.mode != "drum":
            raise ValueError("reel drive_hold needs the drum mode")
