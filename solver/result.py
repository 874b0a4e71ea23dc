"""`SimulationResult`: what a run produced, as arrays over time.

Shaped like python-control's `TimeResponseData`: arrays with named meaning,
`.to_pandas()` for tables, `.plot()` delegating to `solver.plotting`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np
import pandas as pd


@dataclass
class SimulationResult:
    """Arrays over `t` (s). Positions in the tow-point frame (m).

    hose_xyz: (nt, nmax+1, 3) hose nodes, tow point first, NaN past each
        record's last hose node (the count changes when the reel remeshes).
    drogue_xyz: (nt, 3) drogue centre of mass, or None without a drogue.
    tension: (nt, nmax) axial force of each hose element (N), tow end first.
    reel_length, reel_speed: hose outside the pod (m) and its rate (m/s).
    reel_exit_tension: tension of the reel-exit element (N).
    tow_force: (nt, 3) force the hose applies to the tow point (N).
    probe_force: (nt, 3) force the drogue applies to the probe while attached (N).
    energy_kinetic, energy_potential: J (potential: elastic plus gravity).
    n_hose_elements: (nt,) element count at each record.
    hinge_angle_deg: (nt,) angle between the last hose element and the drogue axis.
    balance: (nt, 11) mass and momentum bookkeeping: free-node mass (kg), node 0's
        half-element mass (kg), free-node momentum at the half step (kg m/s, 3),
        cumulative momentum carried across the reel exit (3), cumulative impulse of
        the hose on the tow point (N s, 3).
    """

    t: np.ndarray
    hose_xyz: np.ndarray
    hose_vel: np.ndarray
    tension: np.ndarray
    reel_length: np.ndarray
    reel_speed: np.ndarray
    reel_exit_tension: np.ndarray
    tow_force: np.ndarray
    probe_force: np.ndarray
    energy_kinetic: np.ndarray
    energy_potential: np.ndarray
    n_hose_elements: np.ndarray
    drogue_xyz: Optional[np.ndarray] = None
    drogue_vel: Optional[np.ndarray] = None
    hinge_angle_deg: Optional[np.ndarray] = None
    balance: Optional[np.ndarray] = None
    dt: float = float("nan")
    reel_tension_set: float = 0.0
    provenance: dict = field(default_factory=dict)

    @classmethod
    def from_arrays(cls, model, t, pos, vel, tension, reel, end_force, energy, n_nodes, balance, dt,
                    reel_tension_set):
        nt, n_max, _ = pos.shape
        extra = 1 if model.has_drogue else 0
        nh = n_nodes - 1 - extra          # hose elements per record
        rows = np.arange(nt)
        # hose nodes are 0..nh; with a drogue its node (nh+1) follows and is moved out
        node = np.arange(n_max - extra)[None, :]
        keep = node <= nh[:, None]
        hose_xyz = np.where(keep[..., None], pos[:, :n_max - extra], np.nan)
        hose_vel = np.where(keep[..., None], vel[:, :n_max - extra], np.nan)
        ten = np.where(node[:, :-1] < nh[:, None], tension[:, :n_max - 1 - extra], np.nan)
        drogue = dvel = hinge = None
        if extra:
            drogue = pos[rows, nh + 1].copy()
            dvel = vel[rows, nh + 1].copy()
            a = pos[rows, nh] - pos[rows, nh - 1]
            b = drogue - pos[rows, nh]
            c = np.einsum("ij,ij->i", a, b) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
            hinge = np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))
        return cls(
            t=t, hose_xyz=hose_xyz, hose_vel=hose_vel, tension=ten,
            reel_length=reel[:, 0].copy(), reel_speed=reel[:, 1].copy(),
            reel_exit_tension=reel[:, 2].copy(), tow_force=reel[:, 3:6].copy(),
            probe_force=-end_force.copy(), energy_kinetic=energy[:, 0].copy(),
            energy_potential=energy[:, 1].copy(), n_hose_elements=nh,
            drogue_xyz=drogue, drogue_vel=dvel, hinge_angle_deg=hinge, balance=balance, dt=dt,
            reel_tension_set=reel_tension_set)

    @property
    def energy_total(self) -> np.ndarray:
        return self.energy_kinetic + self.energy_potential

    @property
    def end_xyz(self) -> np.ndarray:
        """The free end: the drogue when there is one, else the last hose node."""
        if self.drogue_xyz is not None:
            return self.drogue_xyz
        idx = self.n_hose_elements
        return self.hose_xyz[np.arange(len(self.t)), idx]

    def hose_points(self, k: int) -> np.ndarray:
        """Hose centre line at record k, tow point first, (m+1, 3)."""
        return self.hose_xyz[k, :self.n_hose_elements[k] + 1]

    def to_pandas(self) -> pd.DataFrame:
        """One row per record, scalar channels with units in the column names."""
        cols = {
            "reel_length_m": self.reel_length,
            "reel_speed_mps": self.reel_speed,
            "reel_exit_tension_N": self.reel_exit_tension,
            "tow_force_x_N": self.tow_force[:, 0],
            "tow_force_y_N": self.tow_force[:, 1],
            "tow_force_z_N": self.tow_force[:, 2],
            "probe_force_x_N": self.probe_force[:, 0],
            "probe_force_y_N": self.probe_force[:, 1],
            "probe_force_z_N": self.probe_force[:, 2],
            "energy_kinetic_J": self.energy_kinetic,
            "energy_potential_J": self.energy_potential,
            "n_hose_elements": self.n_hose_elements,
        }
        end = self.end_xyz
        for c, name in enumerate("xyz"):
            cols[f"end_{name}_m"] = end[:, c]
        if self.hinge_angle_deg is not None:
            cols["hinge_angle_deg"] = self.hinge_angle_deg
        df = pd.DataFrame(cols, index=pd.Index(self.t, name="t_s"))
        return df

    def plot(self, kind: str = "summary", ax=None, **kwargs):
        """Plot the run (`kind`: 'summary', 'shape' or 'end'); see `solver.plotting`."""
        from solver import plotting
        return plotting.plot_result(self, kind=kind, ax=ax, **kwargs)
