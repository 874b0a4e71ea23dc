"""The drogue: a rigid body on a ball hinge at the hose end.

The drogue is an axisymmetric body whose mass sits at its centre of mass, a
distance `cg_aft_of_hinge` behind the hinge along its axis; the solver carries it
as a stiff link from the hose end to that point (roll about its own axis is
ignored, like hose torsion). The hinge is free within +/- `free_play_deg` of the
last hose element and stopped beyond it by a penalty spring; it may add viscous
damping and Coulomb friction. Drag (Eq. 10) acts along the relative wind at the
centre of pressure, lift (Eq. 11) perpendicular to it in the vertical plane
through it, upward.
"""
from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class DrogueProperties:
    mass: float                     # kg
    diameter: float                 # m; reference area pi d^2 / 4
    cd: float                       # drag coefficient on the reference area
    cl: float = 0.0                 # lift coefficient (wind tunnel), upward
    cp_aft_of_hinge: float = 0.35   # m
    cg_aft_of_hinge: float | None = None   # m; default half way to the centre of pressure
    free_play_deg: float = 22.5
    lift_scale: float = 1.0         # in-flight factor on cl (0 flies without lift)
    drag_scale: float = 1.0         # in-flight factor on cd
    hinge_stop_stiffness: float = 5.0e4   # N m/rad beyond the free play
    hinge_damping: float = 0.0      # N m s/rad
    hinge_friction: float = 0.0     # N m

    def __post_init__(self):
        for name in ("mass", "diameter", "cd", "cp_aft_of_hinge", "hinge_stop_stiffness"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"drogue {name} must be a positive finite number, got {v!r}")
        if not (0.0 <= self.free_play_deg < 90.0):
            raise ValueError(f"drogue free_play_deg {self.free_play_deg!r} must lie in [0, 90)")
        if self.cg_aft_of_hinge is not None and self.cg_aft_of_hinge <= 0:
            raise ValueError("drogue cg_aft_of_hinge must be positive")

    @property
    def area(self) -> float:
        return math.pi * self.diameter ** 2 / 4

    @property
    def link_length(self) -> float:
        return self.cg_aft_of_hinge if self.cg_aft_of_hinge is not None else 0.5 * self.cp_aft_of_hinge

    @property
    def drag_area(self) -> float:
        return self.cd * self.drag_scale * self.area

    @property
    def lift_area(self) -> float:
        return self.cl * self.lift_scale * self.area
