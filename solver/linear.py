"""Linearised chain dynamics about a static equilibrium: M x'' + C x' + K x = 0.

Stiffness and damping come from central differences of the solver's own force
kernel (`solver.kernel.compute_forces`) about an equilibrium at rest, with the
lumped node masses; the modes are the eigenpairs of the first-order form. Used
to tune element constants to a measured mode and to shape a release from rest.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from solver.kernel import compute_forces
from solver.model import Model
from solver.state import State


@dataclass
class ChainForces:
    """The kernel's inputs for one chain at one instant, named: `force(pos, vel)`
    evaluates `compute_forces` with these held fixed (the rest lengths, constants
    and masses of `state.rest`, the model's parameters and wind)."""

    t: float
    params: np.ndarray
    n_nodes: int
    n_hose: int
    mass: np.ndarray
    rest: np.ndarray
    k_axial: np.ndarray
    c_axial: np.ndarray
    k_bend: np.ndarray
    c_bend: np.ndarray
    wind: np.ndarray
    _F: np.ndarray = field(init=False, repr=False)
    _tension: np.ndarray = field(init=False, repr=False)
    _work: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        self._F = np.zeros((self.n_nodes, 3))
        self._tension = np.zeros(self.n_nodes)
        self._work = np.zeros((6, self.n_nodes, 3))

    @classmethod
    def of(cls, model: Model, state: State) -> "ChainForces":
        nh = model.n_elements
        n, mass, rest_all, ka, ca, kb, cb = model.build_arrays(nh, state.rest)
        return cls(t=state.t, params=model.params(nh, state.rest), n_nodes=n, n_hose=nh, mass=mass,
                   rest=rest_all, k_axial=ka, c_axial=ca, k_bend=kb, c_bend=cb, wind=model.wind.params)

    def force(self, pos: np.ndarray, vel: np.ndarray) -> np.ndarray:
        """Forces (N) on the free nodes (all but the clamped first), flattened (node-1, xyz)."""
        compute_forces(t=self.t, P=self.params, n=self.n_nodes, nh=self.n_hose, pos=pos, vel=vel,
                       mass=self.mass, rest=self.rest, ka=self.k_axial, ca=self.c_axial,
                       kb=self.k_bend, cb=self.c_bend, wind_par=self.wind,
                       F=self._F, tension=self._tension, work=self._work)
        return self._F[1:].ravel().copy()


@dataclass
class LinearModel:
    """M x'' + C x' + K x = 0 about an equilibrium, over the free nodes' DOFs `dofs`
    (indices into the flattened (node-1, xyz) array)."""

    mass: np.ndarray
    K: np.ndarray
    C: np.ndarray
    dofs: np.ndarray
    n_nodes: int

    def modes(self) -> tuple[np.ndarray, np.ndarray]:
        """Eigenvalues and displacement shapes (columns, full DOF layout) of the
        first-order form [[0, I], [-M^-1 K, -M^-1 C]]."""
        m = len(self.mass)
        A = np.zeros((2 * m, 2 * m))
        A[:m, m:] = np.eye(m)
        A[m:, :m] = -self.K / self.mass[:, None]
        A[m:, m:] = -self.C / self.mass[:, None]
        lam, V = np.linalg.eig(A)
        shapes = np.zeros((3 * (self.n_nodes - 1), len(lam)), dtype=complex)
        shapes[self.dofs] = V[:m]
        return lam, shapes

    def first_mode(self, component: int = 2) -> tuple[float, float]:
        """(damped frequency Hz, damping ratio) of the lowest lightly damped mode
        whose free-end motion lies mostly along `component` (2: z).

        Lowest by natural frequency |lambda|, not by the imaginary part: the
        short elements' zig-zag modes are overdamped, and a close pair of their
        real eigenvalues can come out of the solver as a complex pair with a
        tiny imaginary part. A ring-down shows several cycles, so its mode has
        zeta well below 1/2."""
        lam, shapes = self.modes()
        zeta = -lam.real / np.maximum(np.abs(lam), 1e-300)
        osc = np.flatnonzero((lam.imag > 0) & (zeta < 0.5))
        tip = shapes[-3:, osc]
        share = np.abs(tip[component]) ** 2 / np.maximum(np.sum(np.abs(tip) ** 2, axis=0), 1e-300)
        cand = osc[share > 0.5]
        if len(cand) == 0:
            raise RuntimeError("no lightly damped mode moves the free end along the measured axis")
        k = cand[np.argmin(np.abs(lam[cand]))]
        return float(lam[k].imag / (2.0 * math.pi)), float(zeta[k])

    def static_deflection(self, node: int, force) -> np.ndarray:
        """Displacement (n_nodes, 3) of every node under a small `force` (N) on `node`."""
        f = np.zeros(3 * (self.n_nodes - 1))
        f[3 * (node - 1):3 * node] = force
        dx = np.zeros_like(f)
        dx[self.dofs] = np.linalg.solve(self.K, f[self.dofs])
        return np.vstack([np.zeros(3), dx.reshape(-1, 3)])


def linearize(model: Model, state: State) -> LinearModel:
    """Stiffness K = -dF/dx and damping C = -dF/dv of `solver.kernel.compute_forces`
    about `state` (at rest), by central differences, and the lumped masses.

    Aerodynamic drag goes as |v| v and has no linear part at rest: a linear mode
    carries no air damping (the time simulation of the verification does).
    When the rig lies in the x-z plane the out-of-plane DOFs decouple exactly
    and are dropped."""
    chain = ChainForces.of(model, state)
    force = chain.force
    n, mass = chain.n_nodes, chain.mass
    pos0 = np.ascontiguousarray(state.pos, dtype=float)
    zero = np.zeros_like(pos0)
    m = 3 * (n - 1)
    Kx = np.zeros((m, m))
    Cv = np.zeros((m, m))
    hx = 1e-6 * model.element_length
    for j in range(m):
        i, c = divmod(j, 3)
        p = pos0.copy()
        p[i + 1, c] += hx
        fp = force(p, zero)
        p[i + 1, c] -= 2 * hx
        fm = force(p, zero)
        Kx[:, j] = -(fp - fm) / (2 * hx)
        v = zero.copy()
        v[i + 1, c] = hx
        fp = force(pos0, v)
        v[i + 1, c] = -hx
        fm = force(pos0, v)
        Cv[:, j] = -(fp - fm) / (2 * hx)
    mdiag = np.repeat(mass[1:], 3)
    ydof = np.arange(1, m, 3)
    other = np.setdiff1d(np.arange(m), ydof)
    scale = max(np.max(np.abs(Kx)), 1e-300)
    planar = (np.max(np.abs(pos0[:, 1])) == 0.0 and model.gravity[1] == 0.0
              and np.max(np.abs(Kx[np.ix_(other, ydof)])) < 1e-9 * scale
              and np.max(np.abs(Cv[np.ix_(other, ydof)])) < 1e-9 * max(np.max(np.abs(Cv)), 1e-300))
    dofs = other if planar else np.arange(m)
    return LinearModel(mdiag[dofs], Kx[np.ix_(dofs, dofs)], Cv[np.ix_(dofs, dofs)], dofs, n)
