"""Wind fields: the air velocity in the tow-point frame at any point and time.

The tow-point frame moves with the tanker, so still air flows through it at the
true airspeed along +x (downstream). A wind field is a sum of components, each
a type code and its parameters packed into one float vector so the solver's
compiled inner loop evaluates it without returning to Python (and numba can
cache the compiled loop):

    params = [n_components, type, n_par, p_1 .. p_n_par, type, n_par, ...]

Component types (the builders below pack their parameters; `solver.effects`
says which physical effect each one stands for and where its model comes from):

- UNIFORM: the same velocity everywhere (free stream, steady relative wind).
- VORTEX_WAKE: a steady field of straight vortex filaments with a
  Hallock-Burnham core, plus an axisymmetric Gaussian velocity deficit (the
  tanker's wing and fuselage wake). The field is steady in this frame, so it is
  sampled once on a uniform grid around the hose and interpolated trilinearly;
  points outside the grid get the filament sums themselves.
- FROZEN_1D: a frozen turbulence field convected with the air (Taylor's
  hypothesis): velocities tabulated against xi = x - U t, interpolated linearly.
- MOVING_SOURCE: a point source (m^3/s) whose position follows a uniformly
  sampled table in time (the receiver's bow wave, a Rankine half-body).
- ONE_MINUS_COSINE: a discrete gust front convected with the air.

The hose code only ever calls `wind_eval` and never knows which components are
present. Numba caches `wind_eval` inside the kernel's compiled functions but
only checks the kernel's own source file for changes: after editing this
file, delete `solver/__pycache__/kernel*` so the kernel recompiles.
"""
from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np
from numba import njit

UNIFORM = 0
VORTEX_WAKE = 1
FROZEN_1D = 2
MOVING_SOURCE = 3
ONE_MINUS_COSINE = 4

# VORTEX_WAKE parameter layout (offsets into the component's parameters)
VW_NFIN, VW_NSEMI, VW_CORE = 0, 1, 2
VW_FUS = 3            # fuselage wake: on, x origin, y axis, z axis, U, momentum area, r0^3, growth
VW_GRID = 11          # grid: x0, y0, z0, spacing, nx, ny, nz
VW_HEADER = 18
FIN_STRIDE = 7        # x1 y1 z1 x2 y2 z2 circulation
SEMI_STRIDE = 4       # x y z circulation; the filament runs from the point to x = +inf

FOUR_PI = 4.0 * math.pi
LN2 = math.log(2.0)


@njit(cache=True, inline="always")
def _segment(px, py, pz, ax, ay, az, bx, by, bz, gam, rc2):
    """Velocity at p of a straight vortex segment a->b of circulation gam
    (Biot-Savart, Katz & Plotkin 2001 Eq. 2.68) with a Hallock-Burnham core:
    |r1 x r2|^2 gains rc^2 |r0|^2, so the swirl at distance h from a long
    segment is gam h / (2 pi (h^2 + rc^2)) instead of gam / (2 pi h)."""
    r1x, r1y, r1z = px - ax, py - ay, pz - az
    r2x, r2y, r2z = px - bx, py - by, pz - bz
    cx = r1y * r2z - r1z * r2y
    cy = r1z * r2x - r1x * r2z
    cz = r1x * r2y - r1y * r2x
    r0x, r0y, r0z = bx - ax, by - ay, bz - az
    r0sq = r0x * r0x + r0y * r0y + r0z * r0z
    den = cx * cx + cy * cy + cz * cz + rc2 * r0sq
    n1 = math.sqrt(r1x * r1x + r1y * r1y + r1z * r1z)
    n2 = math.sqrt(r2x * r2x + r2y * r2y + r2z * r2z)
    if den < 1e-30 or n1 < 1e-12 or n2 < 1e-12:
        return 0.0, 0.0, 0.0
    proj = (r0x * r1x + r0y * r1y + r0z * r1z) / n1 - (r0x * r2x + r0y * r2y + r0z * r2z) / n2
    k = gam / FOUR_PI * proj / den
    return k * cx, k * cy, k * cz


@njit(cache=True, inline="always")
def _semi_infinite_x(px, py, pz, ax, ay, az, gam, rc2):
    """Velocity at p of a vortex filament from a to x = +inf along +x (the limit
    of `_segment` as b runs downstream), same core."""
    r1x, r1y, r1z = px - ax, py - ay, pz - az
    # e x r1 with e = +x
    cy = -r1z
    cz = r1y
    h2 = cy * cy + cz * cz
    n1 = math.sqrt(r1x * r1x + h2)
    den = h2 + rc2
    if den < 1e-30 or n1 < 1e-12:
        return 0.0, 0.0, 0.0
    k = gam / FOUR_PI * (1.0 + r1x / n1) / den
    return 0.0, k * cy, k * cz


@njit(cache=True, inline="always")
def _filaments(px, py, pz, p):
    """The VORTEX_WAKE filaments' induced velocity at one point (linear in
    their circulation: what the grid holds)."""
    nfin = int(p[VW_NFIN])
    nsemi = int(p[VW_NSEMI])
    rc2 = p[VW_CORE] * p[VW_CORE]
    ux = 0.0
    uy = 0.0
    uz = 0.0
    k = VW_HEADER
    for _ in range(nfin):
        vx, vy, vz = _segment(px, py, pz, p[k], p[k + 1], p[k + 2], p[k + 3], p[k + 4], p[k + 5],
                              p[k + 6], rc2)
        ux += vx
        uy += vy
        uz += vz
        k += FIN_STRIDE
    for _ in range(nsemi):
        vx, vy, vz = _semi_infinite_x(px, py, pz, p[k], p[k + 1], p[k + 2], p[k + 3], rc2)
        uy += vy
        uz += vz
        k += SEMI_STRIDE
    return ux, uy, uz


@njit(cache=True, inline="always")
def _fuselage_deficit(px, py, pz, p):
    """The VORTEX_WAKE fuselage wake's axial velocity deficit at one point."""
    f = VW_FUS
    if p[f] == 0.0:
        return 0.0
    xi = px - p[f + 1]
    if xi <= 0.0:
        return 0.0
    # self-similar axisymmetric wake (Pope 2000, Sec. 5.2): r_half^3 grows
    # linearly with distance, the centre-line deficit keeps the momentum
    # deficit U * theta_area
    rh2 = (p[f + 6] + p[f + 7] * xi) ** (2.0 / 3.0)
    dy = py - p[f + 2]
    dz = pz - p[f + 3]
    u0 = p[f + 4] * LN2 * p[f + 5] / (math.pi * rh2)
    return u0 * math.exp(-LN2 * (dy * dy + dz * dz) / rh2)


@njit(cache=True)
def _filaments_many(points, p, out):
    for i in range(points.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = _filaments(points[i, 0], points[i, 1], points[i, 2], p)


@njit(cache=True, inline="always")
def _grid_lerp(px, py, pz, p, base):
    """Trilinear interpolation in the VORTEX_WAKE grid; ok = False outside it."""
    g = VW_GRID
    inv_h = 1.0 / p[g + 3]
    fx = (px - p[g]) * inv_h
    fy = (py - p[g + 1]) * inv_h
    fz = (pz - p[g + 2]) * inv_h
    nx = int(p[g + 4])
    ny = int(p[g + 5])
    nz = int(p[g + 6])
    if not (0.0 <= fx < nx - 1 and 0.0 <= fy < ny - 1 and 0.0 <= fz < nz - 1):
        return False, 0.0, 0.0, 0.0
    ix = int(fx)
    iy = int(fy)
    iz = int(fz)
    tx = fx - ix
    ty = fy - iy
    tz = fz - iz
    sz = 3
    sy = nz * 3
    sx = ny * sy
    i0 = base + ix * sx + iy * sy + iz * sz
    out0 = 0.0
    out1 = 0.0
    out2 = 0.0
    for cx in range(2):
        wx = tx if cx == 1 else 1.0 - tx
        for cy in range(2):
            wxy = wx * (ty if cy == 1 else 1.0 - ty)
            j = i0 + cx * sx + cy * sy
            w0 = wxy * (1.0 - tz)
            w1 = wxy * tz
            out0 += w0 * p[j] + w1 * p[j + 3]
            out1 += w0 * p[j + 1] + w1 * p[j + 4]
            out2 += w0 * p[j + 2] + w1 * p[j + 5]
    return True, out0, out1, out2


@njit(cache=True, inline="always")
def _table_slot(s, n, start):
    """Where fractional row s of a table of n rows of three values, packed from
    params index `start`, falls: the index of its lower row's first value and the
    fraction towards the next row, held at the ends."""
    if s <= 0.0:
        return start, 0.0
    if s >= n - 1:
        return start + 3 * (n - 2), 1.0
    m = int(s)
    return start + 3 * m, s - m


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
        elif kind == VORTEX_WAKE:
            base = VW_HEADER + FIN_STRIDE * int(p[VW_NFIN]) + SEMI_STRIDE * int(p[VW_NSEMI])
            for i in range(npoints):
                ok, vx, vy, vz = _grid_lerp(points[i, 0], points[i, 1], points[i, 2], p, base)
                if not ok:
                    vx, vy, vz = _filaments(points[i, 0], points[i, 1], points[i, 2], p)
                out[i, 0] += vx - _fuselage_deficit(points[i, 0], points[i, 1], points[i, 2], p)
                out[i, 1] += vy
                out[i, 2] += vz
        elif kind == FROZEN_1D:
            # p = [U, xi0, dxi, n, rows of (vx, vy, vz)]
            U = p[0]
            inv = 1.0 / p[2]
            n = int(p[3])
            for i in range(npoints):
                s = (points[i, 0] - U * t - p[1]) * inv
                j, f = _table_slot(s, n, 4)
                g = 1.0 - f
                out[i, 0] += g * p[j] + f * p[j + 3]
                out[i, 1] += g * p[j + 1] + f * p[j + 4]
                out[i, 2] += g * p[j + 2] + f * p[j + 5]
        elif kind == MOVING_SOURCE:
            # p = [Q, a, t0, dt, n, rows of (x, y, z)]; exact 1/r^2 outside the
            # radius a (the nose's stand-off from the source: no air is nearer),
            # linear inside so that points within the body stay finite
            Q = p[0]
            a = p[1]
            n = int(p[4])
            j, f = _table_slot((t - p[2]) / p[3], n, 5)
            sx = (1.0 - f) * p[j] + f * p[j + 3]
            sy = (1.0 - f) * p[j + 1] + f * p[j + 4]
            sz = (1.0 - f) * p[j + 2] + f * p[j + 5]
            q = Q / FOUR_PI
            for i in range(npoints):
                dx = points[i, 0] - sx
                dy = points[i, 1] - sy
                dz = points[i, 2] - sz
                r2 = dx * dx + dy * dy + dz * dz
                if r2 >= a * a:
                    c = q / (r2 * math.sqrt(r2))
                else:
                    c = q / (a * a * a)
                out[i, 0] += c * dx
                out[i, 1] += c * dy
                out[i, 2] += c * dz
        elif kind == ONE_MINUS_COSINE:
            # p = [U, t_start, d, full_wave, vx, vy, vz]: the front passes x = 0 at
            # t_start and travels downstream with the air
            for i in range(npoints):
                xi = p[0] * (t - p[1]) - points[i, 0]
                if xi <= 0.0:
                    continue
                if xi >= p[2]:
                    if p[3] == 0.0:
                        g = 1.0
                    elif xi >= 2.0 * p[2]:
                        continue
                    else:
                        g = 0.5 * (1.0 - math.cos(math.pi * xi / p[2]))
                else:
                    g = 0.5 * (1.0 - math.cos(math.pi * xi / p[2]))
                out[i, 0] += g * p[4]
                out[i, 1] += g * p[5]
                out[i, 2] += g * p[6]
        k += 2 + npar


@dataclass
class WindField:
    """A sum of wind components; `velocity(t, points)` is the Python-side view.

    Treat a WindField as immutable (build new ones with `plus`): the packed
    parameter vector is built once and kept, since a tanker-wake grid makes it
    megabytes long and the statics asks for it at every force evaluation."""

    components: list = field(default_factory=list)   # [(type code, parameter array), ...]
    _packed: np.ndarray | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def params(self) -> np.ndarray:
        if self._packed is None:
            parts = [np.array([float(len(self.components))])]
            for kind, par in self.components:
                par = np.asarray(par, dtype=float)
                parts.append(np.array([float(kind), float(len(par))]))
                parts.append(par)
            self._packed = np.concatenate(parts)
        return self._packed

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

    def kinds(self) -> list[int]:
        return [kind for kind, _ in self.components]


def uniform(velocity) -> WindField:
    """The same air velocity (m/s, tow-point frame) everywhere, at all times."""
    v = np.asarray(velocity, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"uniform wind needs three finite components, got {velocity!r}")
    return WindField([(UNIFORM, v.copy())])


def freestream(true_airspeed: float) -> WindField:
    """Still air seen from a tanker flying at `true_airspeed` (m/s)."""
    return uniform([true_airspeed, 0.0, 0.0])


# ---- builders for the effect components ----------------------------------------------

@dataclass(frozen=True)
class FuselageWake:
    """An axisymmetric Gaussian velocity deficit behind a body of drag area
    `drag_area` (m^2) whose wake starts at x_origin on the axis (y, z), in a
    stream U (m/s); r0 is the half-width at the origin (m)."""

    drag_area: float
    x_origin: float
    y_axis: float
    z_axis: float
    U: float
    r0: float
    spreading: float = 0.51     # Pope (2000) Table 5.3, axisymmetric wake


def vortex_wake(finite: np.ndarray, semi: np.ndarray, core_radius: float,
                fuselage: FuselageWake | None = None, box=None, spacing: float = 0.5) -> np.ndarray:
    """Parameters of a VORTEX_WAKE component.

    finite: (n, 7) segments x1 y1 z1 x2 y2 z2 circulation (m^2/s, right-handed
    about a->b); semi: (m, 4) filaments x y z circulation running from the point
    to x = +inf. box: ((xmin, xmax), (ymin, ymax), (zmin, zmax)) in m, the region
    sampled on a grid of `spacing` m (None: no grid, every point summed
    directly)."""
    finite = np.asarray(finite, dtype=float).reshape(-1, FIN_STRIDE)
    semi = np.asarray(semi, dtype=float).reshape(-1, SEMI_STRIDE)
    if not core_radius >= 0:
        raise ValueError("vortex core radius must not be negative")
    head = np.zeros(VW_HEADER)
    head[VW_NFIN] = len(finite)
    head[VW_NSEMI] = len(semi)
    head[VW_CORE] = core_radius
    if fuselage is not None and fuselage.drag_area > 0:
        f = fuselage
        theta = 0.5 * f.drag_area          # momentum-deficit area: D = rho U^2 theta
        head[VW_FUS:VW_FUS + 8] = [1.0, f.x_origin, f.y_axis, f.z_axis, f.U, theta, f.r0 ** 3,
                                   3.0 * f.spreading * LN2 * theta / math.pi]
    # no grid yet: an empty one sends every point to the direct sums
    head[VW_GRID + 3] = 1.0
    body = np.concatenate([head, finite.ravel(), semi.ravel()])
    if box is None:
        return body
    (x0, x1), (y0, y1), (z0, z1) = box
    h = float(spacing)
    shape = tuple(int(math.ceil((hi - lo) / h)) + 1 for lo, hi in box)
    body[VW_GRID:VW_GRID + 7] = [x0, y0, z0, h, *shape]
    # the grid holds the filaments alone, which are linear in circulation: one
    # grid per geometry at unit circulation serves every wake strength (a
    # calibration varies only the strength); the fuselage wake is added exactly
    gam = np.concatenate([finite[:, 6], semi[:, 3]])
    scale = float(np.max(np.abs(gam))) if len(gam) else 0.0
    if scale == 0.0:
        return np.concatenate([body, np.zeros(3 * math.prod(shape))])
    unit = body[:VW_HEADER + finite.size + semi.size].copy()
    unit[VW_FUS:VW_GRID] = 0.0
    unit[VW_HEADER:] /= np.concatenate([np.tile([1.0] * 6 + [scale], len(finite)),
                                        np.tile([1.0] * 3 + [scale], len(semi))])
    return np.concatenate([body, scale * _unit_grid(unit, shape)])


_GRID_CACHE: "OrderedDict[bytes, np.ndarray]" = OrderedDict()
GRID_CACHE_SIZE = 6     # a few MB each: the geometries of one calibration's logs


def _unit_grid(unit: np.ndarray, shape: tuple) -> np.ndarray:
    """The filaments' field on the grid packed in `unit` (read-only, cached)."""
    key = np.round(unit, 9).tobytes()    # strengths differ in the last bits once normalised
    vals = _GRID_CACHE.get(key)
    if vals is None:
        x0, y0, z0, h = unit[VW_GRID:VW_GRID + 4]
        axes = [o + h * np.arange(n) for o, n in zip((x0, y0, z0), shape)]
        pts = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        vals = np.empty_like(pts)
        _filaments_many(np.ascontiguousarray(pts), unit, vals)
        vals = vals.ravel()
        vals.flags.writeable = False
        _GRID_CACHE[key] = vals
        while len(_GRID_CACHE) > GRID_CACHE_SIZE:
            _GRID_CACHE.popitem(last=False)
    else:
        _GRID_CACHE.move_to_end(key)
    return vals


def elliptic_lifting_line(lift: float, density: float, airspeed: float, span: float,
                          x_bound: float, y_centre: float, z_wing: float,
                          n_panels: int = 80) -> tuple[np.ndarray, np.ndarray, float]:
    """Filaments of a straight lifting line with elliptic loading (Prandtl; Anderson,
    Fundamentals of Aerodynamics, Sec. 5.3) and its flat trailing sheet along +x.

    The root circulation Gamma0 = 4 L / (pi rho V b) carries `lift`; the line is cut
    into `n_panels` horseshoes at cosine-spaced stations (finer at the tips,
    where the sheet is strongest), each carrying the loading's mean over its
    panel so the discrete lift is exact. Returns (finite bound segments,
    semi-infinite trailing filaments, Gamma0). In this frame (air along +x, lift
    +z) the bound vortex points to starboard (+y)."""
    if not (lift >= 0 and density > 0 and airspeed > 0 and span > 0):
        raise ValueError("lifting line needs lift >= 0 and positive density, airspeed and span")
    s = 0.5 * span
    g0 = 4.0 * lift / (math.pi * density * airspeed * span)
    th = np.linspace(0.0, math.pi, n_panels + 1)
    y = y_centre - s * np.cos(th)
    # mean of Gamma0 sin(theta) over y in each panel, dy = s sin(theta) dtheta
    prim = 0.5 * th - 0.25 * np.sin(2 * th)
    gam = g0 * s * np.diff(prim) / np.diff(y)
    fin = np.zeros((n_panels, FIN_STRIDE))
    fin[:, 0] = x_bound
    fin[:, 1] = y[:-1]
    fin[:, 2] = z_wing
    fin[:, 3] = x_bound
    fin[:, 4] = y[1:]
    fin[:, 5] = z_wing
    fin[:, 6] = gam
    # trailing filament at each station: the panel to port leaves it downstream
    # (+x, +Gamma), the panel to starboard arrives from downstream (-Gamma)
    g_ext = np.concatenate([[0.0], gam, [0.0]])
    semi = np.zeros((n_panels + 1, SEMI_STRIDE))
    semi[:, 0] = x_bound
    semi[:, 1] = y
    semi[:, 2] = z_wing
    semi[:, 3] = g_ext[:-1] - g_ext[1:]
    return fin, semi, g0


def dryden_table(sigma: float, length_u: float, length_v: float, length_w: float, airspeed: float,
                 xi_min: float, xi_max: float, dxi: float, seed: int) -> np.ndarray:
    """Parameters of a FROZEN_1D component: Dryden turbulence (MIL-HDBK-1797,
    MIL-F-8785C) sampled every `dxi` m along the convected coordinate.

    Each component is its forming filter driven by white noise, discretised
    exactly (see `dryden_series`); x takes the longitudinal spectrum, y and z
    the lateral and vertical ones. Seeded: the same arguments give the same
    field."""
    n = int(math.ceil((xi_max - xi_min) / dxi)) + 2
    rng = np.random.default_rng(seed)
    cols = [dryden_series("u", sigma, length_u, dxi, n, rng),
            dryden_series("v", sigma, length_v, dxi, n, rng),
            dryden_series("w", sigma, length_w, dxi, n, rng)]
    tab = np.column_stack(cols)
    return np.concatenate([[airspeed, xi_min, dxi, n], tab.ravel()])


def dryden_series(component: str, sigma: float, length: float, dx: float, n: int,
                  rng: np.random.Generator) -> np.ndarray:
    """n samples, `dx` m apart, of one Dryden gust component of rms `sigma`.

    The forming filters of MIL-HDBK-1797 in the spatial variable s (1/m):
      u: sigma sqrt(2L/pi) / (1 + L s)
      v, w: sigma sqrt(L/pi) (1 + sqrt(3) L s) / (1 + L s)^2
    whose outputs have the correlations sigma^2 exp(-r/L) and
    sigma^2 (1 - r/2L) exp(-r/L). Written as a linear SDE in x and sampled
    exactly (transition matrix and process-noise covariance from the
    stationary covariance), the samples carry those correlations at every lag
    with no discretisation error, whatever dx."""
    from scipy.linalg import expm, solve_continuous_lyapunov
    from scipy.signal import lfilter
    if not (sigma >= 0 and length > 0 and dx > 0):
        raise ValueError("Dryden series needs sigma >= 0, length > 0 and dx > 0")
    a = 1.0 / length
    if component == "u":
        phi = math.exp(-dx * a)
        e = rng.standard_normal(n)
        y = lfilter([sigma * math.sqrt(1.0 - phi * phi)], [1.0, -phi], e,
                    zi=[phi * sigma * rng.standard_normal()])[0]
        return y
    if component not in ("v", "w"):
        raise ValueError(f"Dryden component must be u, v or w, got {component!r}")
    A = np.array([[0.0, 1.0], [-a * a, -2.0 * a]])
    B = np.array([[0.0], [1.0]])
    C = np.array([1.0, math.sqrt(3.0) * length])   # zero at s = -1/(sqrt(3) L)
    Pss = solve_continuous_lyapunov(A, -B @ B.T)
    C = C * sigma / math.sqrt(C @ Pss @ C)
    Phi = expm(A * dx)
    Qd = Pss - Phi @ Pss @ Phi.T
    G = np.linalg.cholesky(0.5 * (Qd + Qd.T))
    # y = C (zI - Phi)^-1 G e: an ARMA(2,1) per noise input; the state starts
    # stationary through a burn-in of 25 correlation lengths (transient e^-25)
    burn = int(math.ceil(25.0 * length / dx))
    den = np.array([1.0, -np.trace(Phi), np.linalg.det(Phi)])
    # adj(zI - Phi) = z I + M: numerator C g z^-1 + C M g z^-2 over den in z^-1
    M = np.array([[-Phi[1, 1], Phi[0, 1]], [Phi[1, 0], -Phi[0, 0]]])
    y = np.zeros(n + burn)
    for j in range(2):
        g = G[:, j]
        b1 = C @ g
        b2 = C @ M @ g
        e = rng.standard_normal(n + burn)
        y += lfilter([0.0, b1, b2], den, e)
    return y[burn:]


def dryden_psd(component: str, sigma: float, length: float, omega: np.ndarray) -> np.ndarray:
    """One-sided Dryden spectrum (m^2/s^2 per rad/m) at spatial frequencies omega
    (rad/m), MIL-HDBK-1797: integrates to sigma^2 over omega in [0, inf)."""
    w = np.asarray(omega, dtype=float) * length
    if component == "u":
        return sigma ** 2 * 2 * length / math.pi / (1 + w * w)
    return sigma ** 2 * length / math.pi * (1 + 3 * w * w) / (1 + w * w) ** 2


def moving_source(volume_flux: float, standoff: float, t0: float, dt: float,
                  positions: np.ndarray) -> np.ndarray:
    """Parameters of a MOVING_SOURCE component: a point source of `volume_flux`
    (m^3/s) at `positions` (n, 3) sampled every dt s from t0."""
    pos = np.asarray(positions, dtype=float)
    if pos.ndim != 2 or pos.shape[1] != 3 or len(pos) < 2:
        raise ValueError("moving source needs at least two positions (n, 3)")
    if not (dt > 0 and standoff > 0):
        raise ValueError("moving source needs dt > 0 and a positive stand-off radius")
    return np.concatenate([[volume_flux, standoff, t0, dt, len(pos)], pos.ravel()])


def one_minus_cosine(airspeed: float, t_start: float, length: float, full_wave: bool,
                     amplitude) -> np.ndarray:
    """Parameters of a ONE_MINUS_COSINE gust (MIL-HDBK-1797 discrete gust):
    v = V_m/2 (1 - cos(pi xi / d_m)) over the ramp length d_m, then V_m held
    (or, `full_wave`, back to zero over another d_m). xi is how far the front
    has travelled past a point; it passes the tow point at t_start and is
    carried downstream at the airspeed."""
    amp = np.asarray(amplitude, dtype=float)
    if amp.shape != (3,) or not (length > 0):
        raise ValueError("gust needs a positive length and three amplitude components")
    return np.concatenate([[airspeed, t_start, length, 1.0 if full_wave else 0.0], amp])
