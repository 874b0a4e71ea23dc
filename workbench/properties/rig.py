"""The bench rigs as N-element solver models, their static equilibrium and first mode.

The bending rig is a horizontal cantilever clamped at the root, sagging under
gravity in still air at the measured temperature; the axial rig hangs from a
clamp with the end weight on its lower end. The mode comes from the linearised
model (`solver.linear`) about the static (sagged or stretched) equilibrium.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from solver.atmosphere import isa
from solver.hose import HoseProperties
from solver.linear import LinearModel, linearize
from solver.model import Clamp, Model
from solver.state import State
from solver.statics import solve_static
from solver.units import degF_to_K
from workbench.errors import InputError
from workbench.hardware import HoseSheet

# Equilibrium residual relative to the section's weight: tight enough that the
# mode computed about it is steady to ~1e-9 (tuning then does not chase noise),
# loose enough for the round-off of the stiffest (64-element) axial springs.
STATIC_TOL = 1e-8


@dataclass(frozen=True)
class BenchRig:
    """A bench-test section as modelled: the hose from its data sheet, empty of
    fuel, `length` m long; `hanging` for the axial rig (clamped above, the end
    weight `tip_mass` kg below), else a horizontal cantilever (the tip
    accelerometer's mass is not on record and is left out)."""

    hose: str
    length: float
    outer_diameter: float
    inner_diameter: float
    dry_mass_per_length: float
    hanging: bool = False
    tip_mass: float = 0.0

    @classmethod
    def from_sheet(cls, sheet: HoseSheet, length: float | None, hanging: bool = False,
                   tip_mass: float | None = None) -> "BenchRig":
        L = length if length is not None else sheet.bench_section_length
        if L is None:
            raise InputError(f"hose {sheet.id}: no section_length_m in the records and no "
                             f"bench_section_length_m on the data sheet")
        return cls(sheet.id, float(L), sheet.outer_diameter, sheet.inner_diameter,
                   sheet.dry_mass_per_length, hanging, float(tip_mass or 0.0))

    @property
    def clamp_direction(self) -> tuple:
        return (0.0, 0.0, -1.0) if self.hanging else (1.0, 0.0, 0.0)

    def model(self, n_elements: int, constants, temperature_F: float) -> Model:
        """`constants` is a 4-tuple for every element, or an `element_constants` callable."""
        l = self.length / n_elements
        fn = constants if callable(constants) else (lambda _l, c=tuple(constants): c)
        ka, ca, kb, cb = fn(l)
        hose = HoseProperties(length=self.length, outer_diameter=self.outer_diameter,
                              inner_diameter=self.inner_diameter,
                              dry_mass_per_length=self.dry_mass_per_length,
                              EI=kb * l, EA=ka * l, bending_damping=cb * l, axial_damping=ca * l,
                              fuel_full=False, element_constants=fn)
        # still air in the rig at the measured temperature
        atm = isa(0.0, delta_temperature=degF_to_K(temperature_F) - isa(0.0).temperature)
        return Model(hose, n_elements, atm.density, atm.kinematic_viscosity,
                     clamp=Clamp(self.clamp_direction), tip_mass=self.tip_mass)

    def straight(self, n_elements: int) -> np.ndarray:
        return np.outer(np.linspace(0.0, self.length, n_elements + 1), self.clamp_direction)


def equilibrium(model: Model, guess: np.ndarray) -> State:
    """Static equilibrium from `guess` (the solver's string guess hangs a
    cantilever straight down, far from its sagged shape)."""
    return solve_static(model, tol=STATIC_TOL, guess=guess)


def rig_mode(rig: BenchRig, n_elements: int, constants, temperature_F: float,
             guess: np.ndarray | None = None) -> tuple[float, float, State, LinearModel]:
    """First mode of the rig along z (bending: transverse; hanging: axial)."""
    model = rig.model(n_elements, constants, temperature_F)
    st = equilibrium(model, rig.straight(n_elements) if guess is None else guess)
    lin = linearize(model, st)
    f, z = lin.first_mode(2)
    return f, z, st, lin


def second_moment_of_area(sheet: HoseSheet) -> float:
    """pi (D^4 - d^4) / 64 of the data sheet's outer and inner diameters, m^4."""
    return math.pi * (sheet.outer_diameter ** 4 - sheet.inner_diameter ** 4) / 64.0

