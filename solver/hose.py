"""Hose properties and their discretisation into rigid elements.

Formulation (documented once, here):
- The hose is N rigid elements between N+1 nodes; node 0 is the tow point (reel
  exit). Each element's mass (hose + fuel inside, mu l) is lumped half on each of
  its end nodes, which gives the right total mass and centre of mass; the lumped
  form carries each element's rotary inertia as m l^2/4 instead of m l^2/12, an
  O(l^2) difference that vanishes as N grows (the cantilever convergence test
  shows the rate).
- Axial: each element stretches with a linear spring-damper (Eq. 1), tension
  T = k_a (l - l_0) + c_a dl/dt. For a continuum of axial stiffness EA and axial
  damping eta_a (N s), k_a = EA / l_0 and c_a = eta_a / l_0.
- Bending: at every joint a rotational spring-damper (Eq. 2) acts on the angle
  theta between neighbouring elements, M = k_b theta + c_b dtheta/dt, about the
  joint's bending axis (both bending directions: the moment is a vector). A
  joint stands for one element length of beam, so k_b = EI / l and c_b = eta_b / l
  with eta_b (N m^2 s) the bending damping of the continuum. In Eq. 2's terms,
  omega_0^2 = k_b / I and 2 zeta omega_0 = c_b / I for an element's inertia I.
- Torsion about the hose axis is ignored: the hose is axisymmetric, no load in
  this problem twists it, and its torsion mode does not couple with bending at
  the amplitudes of interest. Moments along an element's axis are dropped.

Per-element constants from a property table (tuned for one element length)
replace the continuum relations by passing `element_constants`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Optional


@dataclass(frozen=True)
class HoseProperties:
    """A hose as built. Lengths in m, masses in kg."""

    length: float                  # hose outside the pod at the start, m
    outer_diameter: float
    inner_diameter: float
    dry_mass_per_length: float     # kg/m
    EI: float                      # bending stiffness, N m^2
    EA: float                      # axial stiffness, N
    bending_damping: float = 0.0   # eta_b, N m^2 s
    axial_damping: float = 0.0     # eta_a, N s
    fuel_density: float = 810.0    # kg/m^3
    fuel_full: bool = True
    cdn: float = 1.2               # crossflow drag coefficient (Hoerner)
    cdn_regimes: bool = True       # Eq. 7 Reynolds-number regimes
    ca0: float = 0.004             # skin friction on the wetted area
    total_length: Optional[float] = None   # outside + on the drum; defaults to `length`
    # optional per-element constants (k_a, c_a, k_b, c_b) as a function of element length
    element_constants: Optional[Callable[[float], tuple]] = None

    def __post_init__(self):
        for name in ("length", "outer_diameter", "dry_mass_per_length", "EI", "EA"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"hose {name} must be a positive finite number, got {v!r}")
        if not (0 <= self.inner_diameter < self.outer_diameter):
            raise ValueError(
                f"hose inner_diameter {self.inner_diameter!r} must lie in [0, outer_diameter)")
        for name in ("bending_damping", "axial_damping", "ca0"):
            if getattr(self, name) < 0:
                raise ValueError(f"hose {name} must not be negative")
        if self.total_length is not None and self.total_length < self.length:
            raise ValueError("hose total_length is shorter than the length outside the pod")

    @property
    def mass_per_length(self) -> float:
        """Hose plus the fuel it holds (when full), kg/m."""
        fuel = self.fuel_density * math.pi * self.inner_diameter ** 2 / 4 if self.fuel_full else 0.0
        return self.dry_mass_per_length + fuel

    @property
    def stowed_length(self) -> float:
        return self.total_length if self.total_length is not None else self.length

    def constants(self, element_length: float) -> tuple[float, float, float, float]:
        """(k_a N/m, c_a N s/m, k_b N m/rad, c_b N m s/rad) of an element of this length."""
        if self.element_constants is not None:
            return tuple(float(x) for x in self.element_constants(element_length))
        l = element_length
        return (self.EA / l, self.axial_damping / l, self.EI / l, self.bending_damping / l)
