"""The compiled inner loop: forces on the node chain and leapfrog time stepping.

Discretisation (see docs in `solver/hose.py`): nodes 0..nh are the ends of the nh
rigid hose elements, node 0 at the tow point (reel exit). With a drogue, node nh+1
is the drogue's centre of mass, joined to the hose end (the hinge, node nh) by a
stiff link: element nh. Element e joins nodes e and e+1.

Everything here works on flat arrays and a scalar parameter vector `P` (indices
below) so that numba compiles it once; the Python side (`solver.integrate`)
prepares the arrays, handles the reel's remeshing and turns codes into errors.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from solver.wind import wind_eval

# ---- indices into the scalar parameter vector P -------------------------------------
P_RHO = 0          # air density, kg/m^3
P_NU = 1           # kinematic viscosity, m^2/s
P_GX, P_GY, P_GZ = 2, 3, 4   # gravity vector, m/s^2
P_DIAM = 5         # hose outer diameter, m
P_CA0 = 6          # skin-friction coefficient on the wetted area
P_CDN = 7          # crossflow drag coefficient when regimes are off
P_CDN_REGIMES = 8  # 1: Eq. 7 Reynolds-number regimes, 0: constant P_CDN
P_HOSE_DRAG = 9    # scale on hose crossflow and skin friction (1 = baseline)
P_HAS_DROGUE = 10
P_CDA = 11         # drogue drag coefficient x area, m^2
P_CLA = 12         # drogue lift coefficient x area, m^2 (already scaled)
P_CP_FRAC = 13     # centre of pressure position along the link / link length
P_HINGE_FREE = 14  # free-play half angle, rad
P_HINGE_KPEN = 15  # penalty stiffness beyond the free play, N m/rad
P_HINGE_C = 16     # hinge viscous damping, N m s/rad
P_HINGE_FRIC = 17  # hinge Coulomb friction torque, N m
P_CLAMP = 18       # 1: element 0 is clamped in direction P_CLAMP_DIR at the tow point
P_CLAMP_DX, P_CLAMP_DY, P_CLAMP_DZ = 19, 20, 21
P_CLAMP_K = 22     # N m/rad
P_CLAMP_C = 23     # N m s/rad
P_END_MODE = 24    # 1: the last node follows the end table between P_END_ON and P_END_OFF
P_END_ON = 25
P_END_OFF = 26
P_REEL_MODE = 27   # 0 locked, 1 prescribed table, 2 drum with torque law
P_MU = 28          # hose mass per length incl. fuel, kg/m
P_EA0 = 29         # axial stiffness x length of the reel-exit element, N
P_ETA_A0 = 30      # axial damping x length of the reel-exit element, N s
P_EI1 = 31         # bending stiffness x length at joint 1, N m^2
P_ETA_B1 = 32      # bending damping x length at joint 1, N m^2 s
P_L_NOM = 33       # nominal element length, m (remeshing thresholds)
P_DRUM_R0 = 34     # empty drum radius, m
P_DRUM_W = 35      # drum width, m
P_DRUM_I0 = 36     # empty drum inertia, kg m^2
P_HOSE_TOTAL = 37  # total hose length (outside + wound), m
P_TORQUE_LAW = 38  # 0 constant torque, 1 constant tension
P_TORQUE = 39      # N m (law 0) or tension N (law 1)
P_VMAX = 40        # divergence threshold on any node speed, m/s
P_NE_MIN = 41      # fewest hose elements remeshing may leave
P_HOSE_REST_SUM = 44  # sum of rest lengths of hose elements 1..nh-1 (element 0 takes the rest)
P_EXTRA_MASS0 = 45    # mass lumped on node 1 besides its half elements (normally 0)
P_REEL_HOLD = 46      # reel drive hold-back b, N s/m at the drum rim (0: none; `_drive_hold`)
P_REEL_LAG = 47       # first-order lag of the drive's speed reference, s
P_END_K = 48   # probe coupling stiffness, N/m (0: the end follows its table rigidly)
P_END_C = 49   # probe coupling damping, N s/m
NP = 50

# the drive hold-back's state in the `reel` array (after the 10 bookkeeping slots):
# the lagged speed reference, the ring position, then a ring of past payout speeds
# whose length is the dead time in steps (`solver.integrate` sizes it)
REEL_FILT = 10
REEL_RING_POS = 11
REEL_RING = 12

# ---- kernel return codes ----------------------------------------------------------
OK = 0
NONFINITE = 1
OVERSPEED = 2
REMESH_GROW = 3
REMESH_SHRINK = 4
REEL_LIMIT = 5

# the reel-exit element is split above REMESH_MAX and merged below REMESH_MIN
# nominal lengths; split and merge both land inside the band
REMESH_MIN = 0.75
REMESH_MAX = 1.75


@njit(cache=True)
def _interp_table(tab_t0, tab_dt, tab, t, out):
    """Linear interpolation in a uniformly sampled table (rows are samples), held at the ends."""
    n = tab.shape[0]
    s = (t - tab_t0) / tab_dt
    if s <= 0.0:
        for k in range(tab.shape[1]):
            out[k] = tab[0, k]
        return
    if s >= n - 1:
        for k in range(tab.shape[1]):
            out[k] = tab[n - 1, k]
        return
    i = int(s)
    f = s - i
    for k in range(tab.shape[1]):
        out[k] = tab[i, k] * (1.0 - f) + tab[i + 1, k] * f


@njit(cache=True)
def _cdn(P, re):
    """Crossflow drag coefficient, Eq. 7, with a +/-3 % linear blend at each step in Re
    so that the Newton statics sees a continuous function."""
    if P[P_CDN_REGIMES] == 0.0:
        return P[P_CDN]
    a1, a2 = 3.0e5, 7.0e5
    w = 0.03
    if re < a1 * (1 - w):
        return 1.2
    if re < a1 * (1 + w):
        f = (re - a1 * (1 - w)) / (2 * w * a1)
        return 1.2 + f * (0.3 - 1.2)
    if re < a2 * (1 - w):
        return 0.3
    if re < a2 * (1 + w):
        f = (re - a2 * (1 - w)) / (2 * w * a2)
        return 0.3 + f * (0.6 - 0.3)
    return 0.6


@njit(cache=True, inline="always")
def _angle(s, c):
    """Angle between two unit vectors from |a x b| = s and a.b = c. Joints bend a
    little almost everywhere: below s = 0.1 the arcsine series (error < 1e-8 rad)
    stands in for atan2, which costs more than the rest of the joint."""
    if c > 0.0 and s < 0.1:
        s2 = s * s
        return s * (1.0 + s2 * (1.0 / 6.0 + s2 * (3.0 / 40.0 + s2 * (5.0 / 112.0))))
    return math.atan2(s, c)


@njit(cache=True, inline="always")
def _theta_over_sin(s, c, th):
    """theta / sin(theta), continuous through theta = 0."""
    if s > 1e-9:
        return th / s
    return 1.0 + s * s / 6.0


@njit(cache=True, inline="always")
def _theta_over_sin_direct(s, c):
    """theta / sin(theta) from s = sin(theta) and c = cos(theta) without a division
    for the small angles almost every joint has: the series of arcsin(s)/s (the
    `_angle` series over s, error < 1e-8 below s = 0.1)."""
    if c > 0.0 and s < 0.1:
        s2 = s * s
        return 1.0 + s2 * (1.0 / 6.0 + s2 * (3.0 / 40.0 + s2 * (5.0 / 112.0)))
    return _theta_over_sin(s, c, _angle(s, c))


@njit(cache=True)
def drum_radius_inertia(P, L_out):
    """Drum radius and inertia with (P_HOSE_TOTAL - L_out) of hose wound on it.

    Wound hose fills the drum's annulus with one hose diameter squared of cross
    section per metre (square packing): pi (R^2 - R0^2) w = L_wound D^2. The wound
    hose (with its fuel) adds the inertia of a thick annulus."""
    R0 = P[P_DRUM_R0]
    D = P[P_DIAM]
    lw = P[P_HOSE_TOTAL] - L_out
    if lw < 0.0:
        lw = 0.0
    R = math.sqrt(R0 * R0 + lw * D * D / (math.pi * P[P_DRUM_W]))
    I = P[P_DRUM_I0] + P[P_MU] * lw * 0.5 * (R * R + R0 * R0)
    return R, I


@njit(cache=True)
def _drive_hold(P, reel, dt):
    """Rim force (N, against payout) of the reel drive's hold-back: b (v - v_f), v
    the payout speed and v_f the speed the ring of past speeds returns (dead time)
    through a first-order lag. Advances the ring and the lag by one step."""
    if reel.shape[0] < REEL_RING:
        return 0.0      # a caller that keeps no hold-back state gets none
    nb = reel.shape[0] - REEL_RING
    v = reel[1]
    if nb > 0:
        pos = int(reel[REEL_RING_POS])
        v_old = reel[REEL_RING + pos]
        reel[REEL_RING + pos] = v
        reel[REEL_RING_POS] = (pos + 1) % nb
    else:
        v_old = v
    tau = P[P_REEL_LAG]
    alpha = 1.0 - math.exp(-dt / tau) if tau > 0.0 else 1.0
    reel[REEL_FILT] += alpha * (v_old - reel[REEL_FILT])
    return P[P_REEL_HOLD] * (v - reel[REEL_FILT])


# Fast-math without the no-NaN/no-Inf assumptions, so divergence checks still see them.
FAST = {"contract", "arcp", "nsz", "afn", "reassoc"}


@njit(cache=True, fastmath=FAST)
def compute_forces(t, P, n, nh, pos, vel, mass, rest, ka, ca, kb, cb, wind_par,
                   F, tension, work):
    """Forces on every node (gravity, axial, bending, hinge, hose and drogue aero).

    `tension[e]` receives the axial force of element e (positive in tension).
    `work` is scratch of shape (6, >= n, 3): unit tangents, angular velocities,
    inverse lengths (first column), midpoints and wind velocities of the
    elements, and the drogue's centre of pressure.
    Returns the element count actually used (ne)."""
    ne = n - 1
    g0, g1, g2 = P[P_GX], P[P_GY], P[P_GZ]
    for i in range(n):
        F[i, 0] = mass[i] * g0
        F[i, 1] = mass[i] * g1
        F[i, 2] = mass[i] * g2
    tang = work[0]
    omeg = work[1]
    inv_len = work[2][:, 0]
    mids = work[3]
    # element geometry, axial spring-dampers (Eq. 1), element angular velocities
    for e in range(ne):
        dx = pos[e + 1, 0] - pos[e, 0]
        dy = pos[e + 1, 1] - pos[e, 1]
        dz = pos[e + 1, 2] - pos[e, 2]
        l = math.sqrt(dx * dx + dy * dy + dz * dz)
        inv = 1.0 / l
        tx, ty, tz = dx * inv, dy * inv, dz * inv
        dvx = vel[e + 1, 0] - vel[e, 0]
        dvy = vel[e + 1, 1] - vel[e, 1]
        dvz = vel[e + 1, 2] - vel[e, 2]
        ldot = tx * dvx + ty * dvy + tz * dvz
        T = ka[e] * (l - rest[e]) + ca[e] * ldot
        tension[e] = T
        F[e, 0] += T * tx
        F[e, 1] += T * ty
        F[e, 2] += T * tz
        F[e + 1, 0] -= T * tx
        F[e + 1, 1] -= T * ty
        F[e + 1, 2] -= T * tz
        tang[e, 0], tang[e, 1], tang[e, 2] = tx, ty, tz
        inv_len[e] = inv
        # omega = t x (dv / l): the element's rotation rate about its centre
        omeg[e, 0] = (ty * dvz - tz * dvy) * inv
        omeg[e, 1] = (tz * dvx - tx * dvz) * inv
        omeg[e, 2] = (tx * dvy - ty * dvx) * inv
        mids[e, 0] = 0.5 * (pos[e, 0] + pos[e + 1, 0])
        mids[e, 1] = 0.5 * (pos[e, 1] + pos[e + 1, 1])
        mids[e, 2] = 0.5 * (pos[e, 2] + pos[e + 1, 2])

    has_drogue = P[P_HAS_DROGUE] != 0.0
    # joint moments: bending (Eq. 2) at hose joints, the ball hinge at node nh
    njoint_last = nh if has_drogue else nh - 1
    for j in range(1, njoint_last + 1):
        a = j - 1
        b = j
        ax, ay, az = tang[a, 0], tang[a, 1], tang[a, 2]
        bx, by, bz = tang[b, 0], tang[b, 1], tang[b, 2]
        nx = ay * bz - az * by
        ny = az * bx - ax * bz
        nz = ax * by - ay * bx
        s = math.sqrt(nx * nx + ny * ny + nz * nz)
        c = ax * bx + ay * by + az * bz
        wx = omeg[b, 0] - omeg[a, 0]
        wy = omeg[b, 1] - omeg[a, 1]
        wz = omeg[b, 2] - omeg[a, 2]
        if j < nh or not has_drogue:
            # moment vector on element a: k theta n_hat + c (w_b - w_a)
            fac = _theta_over_sin_direct(s, c)
            kk = kb[j] * fac
            mx = kk * nx + cb[j] * wx
            my = kk * ny + cb[j] * wy
            mz = kk * nz + cb[j] * wz
        else:
            # ball hinge: free inside the play, penalty spring outside, damping, friction
            th = _angle(s, c)
            mel = 0.0
            if th > P[P_HINGE_FREE]:
                mel = P[P_HINGE_KPEN] * (th - P[P_HINGE_FREE])
            fac = mel / s if s > 1e-9 else 0.0
            mx = fac * nx + P[P_HINGE_C] * wx
            my = fac * ny + P[P_HINGE_C] * wy
            mz = fac * nz + P[P_HINGE_C] * wz
            if P[P_HINGE_FRIC] > 0.0:
                wn = math.sqrt(wx * wx + wy * wy + wz * wz)
                if wn > 1e-12:
                    # tanh regularisation of Coulomb friction at 0.05 rad/s
                    f = P[P_HINGE_FRIC] * math.tanh(wn / 0.05) / wn
                    mx += f * wx
                    my += f * wy
                    mz += f * wz
        _apply_torque(F, a, tang, inv_len, mx, my, mz, 1.0)
        _apply_torque(F, b, tang, inv_len, mx, my, mz, -1.0)

    if P[P_CLAMP] != 0.0:
        # rotational spring between the fixed clamp direction and element 0
        ax, ay, az = P[P_CLAMP_DX], P[P_CLAMP_DY], P[P_CLAMP_DZ]
        bx, by, bz = tang[0, 0], tang[0, 1], tang[0, 2]
        nx = ay * bz - az * by
        ny = az * bx - ax * bz
        nz = ax * by - ay * bx
        s = math.sqrt(nx * nx + ny * ny + nz * nz)
        c = ax * bx + ay * by + az * bz
        fac = _theta_over_sin_direct(s, c)
        kk = P[P_CLAMP_K] * fac
        mx = kk * nx + P[P_CLAMP_C] * omeg[0, 0]
        my = kk * ny + P[P_CLAMP_C] * omeg[0, 1]
        mz = kk * nz + P[P_CLAMP_C] * omeg[0, 2]
        _apply_torque(F, 0, tang, inv_len, mx, my, mz, -1.0)

    # aerodynamics of hose elements (Eq. 3-9) on the relative wind at each element centre
    nhe = nh
    wvel = work[4]
    wind_eval(t, mids, nhe, wind_par, wvel)
    rho = P[P_RHO]
    D = P[P_DIAM]
    scale = P[P_HOSE_DRAG]
    regimes = P[P_CDN_REGIMES] != 0.0
    cdn = P[P_CDN]
    re_per_speed = D / P[P_NU]
    qn_coef = 0.5 * rho * D * scale
    qa_coef = 0.5 * rho * P[P_CA0] * math.pi * D * scale
    for e in range(nhe):
        tx, ty, tz = tang[e, 0], tang[e, 1], tang[e, 2]
        rx = wvel[e, 0] - 0.5 * (vel[e, 0] + vel[e + 1, 0])
        ry = wvel[e, 1] - 0.5 * (vel[e, 1] + vel[e + 1, 1])
        rz = wvel[e, 2] - 0.5 * (vel[e, 2] + vel[e + 1, 2])
        u = rx * tx + ry * ty + rz * tz
        nxv = rx - u * tx
        nyv = ry - u * ty
        nzv = rz - u * tz
        vn = math.sqrt(nxv * nxv + nyv * nyv + nzv * nzv)
        l0 = rest[e]
        if regimes:
            cdn = _cdn(P, vn * re_per_speed)
        qn = qn_coef * cdn * l0 * vn
        qa = qa_coef * l0 * abs(u) * u
        fx = 0.5 * (qn * nxv + qa * tx)
        fy = 0.5 * (qn * nyv + qa * ty)
        fz = 0.5 * (qn * nzv + qa * tz)
        F[e, 0] += fx
        F[e, 1] += fy
        F[e, 2] += fz
        F[e + 1, 0] += fx
        F[e + 1, 1] += fy
        F[e + 1, 2] += fz

    if has_drogue:
        # drogue drag along, and lift perpendicular to, the relative wind at the
        # centre of pressure (Eq. 10-11); lift lies in the plane of the relative
        # wind and the frame's z axis, pointing up.
        h = nh
        d = nh + 1
        s = P[P_CP_FRAC]
        cpp = work[5]
        cpp[0, 0] = pos[h, 0] + s * (pos[d, 0] - pos[h, 0])
        cpp[0, 1] = pos[h, 1] + s * (pos[d, 1] - pos[h, 1])
        cpp[0, 2] = pos[h, 2] + s * (pos[d, 2] - pos[h, 2])
        wind_eval(t, cpp, 1, wind_par, wvel)
        rx = wvel[0, 0] - (vel[h, 0] + s * (vel[d, 0] - vel[h, 0]))
        ry = wvel[0, 1] - (vel[h, 1] + s * (vel[d, 1] - vel[h, 1]))
        rz = wvel[0, 2] - (vel[h, 2] + s * (vel[d, 2] - vel[h, 2]))
        V = math.sqrt(rx * rx + ry * ry + rz * rz)
        q = 0.5 * rho * V
        fx = q * P[P_CDA] * rx
        fy = q * P[P_CDA] * ry
        fz = q * P[P_CDA] * rz
        if V > 1e-9 and P[P_CLA] != 0.0:
            ux, uy, uz = rx / V, ry / V, rz / V
            lx, ly, lz = -uz * ux, -uz * uy, 1.0 - uz * uz
            ln = math.sqrt(lx * lx + ly * ly + lz * lz)
            if ln > 1e-9:
                lift = q * V * P[P_CLA] / ln
                fx += lift * lx
                fy += lift * ly
                fz += lift * lz
        F[h, 0] += (1.0 - s) * fx
        F[h, 1] += (1.0 - s) * fy
        F[h, 2] += (1.0 - s) * fz
        F[d, 0] += s * fx
        F[d, 1] += s * fy
        F[d, 2] += s * fz
    return ne


@njit(cache=True, inline="always")
def _apply_torque(F, e, tang, inv_len, mx, my, mz, sign):
    """Apply torque sign*m to element e as a force couple on its end nodes.

    A couple f at the far node and -f at the near one, f = (m x t)/l, has moment
    t x (m x t) = m_perp about the element centre: the axial part of m (torsion,
    neglected in this model) is dropped."""
    tx, ty, tz = tang[e, 0], tang[e, 1], tang[e, 2]
    inv = sign * inv_len[e]
    fx = (my * tz - mz * ty) * inv
    fy = (mz * tx - mx * tz) * inv
    fz = (mx * ty - my * tx) * inv
    F[e + 1, 0] += fx
    F[e + 1, 1] += fy
    F[e + 1, 2] += fz
    F[e, 0] -= fx
    F[e, 1] -= fy
    F[e, 2] -= fz


@njit(cache=True, inline="always")
def _joint_angle(ax, ay, az, bx, by, bz):
    """Angle between unit vectors a and b, atan2(|a x b|, a.b)."""
    nx = ay * bz - az * by
    ny = az * bx - ax * bz
    nz = ax * by - ay * bx
    c = min(1.0, max(-1.0, ax * bx + ay * by + az * bz))
    return math.atan2(math.sqrt(nx * nx + ny * ny + nz * nz), c)


@njit(cache=True)
def potential_energy(P, n, nh, pos, rest, ka, kb):
    """Elastic (axial, bending, hinge penalty, clamp) plus gravity energy relative to z=0.

    Scalar code throughout: the kernel calls this at every record, and array
    temporaries here cost more than the time step itself."""
    E = 0.0
    has_drogue = P[P_HAS_DROGUE] != 0.0
    last = nh if has_drogue else nh - 1
    px = py = pz = 0.0      # unit tangent of the previous element
    for e in range(n - 1):
        dx = pos[e + 1, 0] - pos[e, 0]
        dy = pos[e + 1, 1] - pos[e, 1]
        dz = pos[e + 1, 2] - pos[e, 2]
        l = math.sqrt(dx * dx + dy * dy + dz * dz)
        tx, ty, tz = dx / l, dy / l, dz / l
        E += 0.5 * ka[e] * (l - rest[e]) ** 2
        j = e
        if 1 <= j <= last:
            th = _joint_angle(px, py, pz, tx, ty, tz)
            if j < nh or not has_drogue:
                E += 0.5 * kb[j] * th * th
            elif th > P[P_HINGE_FREE]:
                E += 0.5 * P[P_HINGE_KPEN] * (th - P[P_HINGE_FREE]) ** 2
        if e == 0 and P[P_CLAMP] != 0.0:
            th = _joint_angle(P[P_CLAMP_DX], P[P_CLAMP_DY], P[P_CLAMP_DZ], tx, ty, tz)
            E += 0.5 * P[P_CLAMP_K] * th * th
        px, py, pz = tx, ty, tz
    return E


@njit(cache=True, fastmath=FAST)
def _implicit_axial_damping(dt, n, ca, tang, vel_half, F, inv_m, v_star, tension, tri):
    """Add each element's axial damping force D_e (tension, along its unit tangent t_e)
    taken at the mean of the old and new half-step velocities, to F and `tension`.

    With v* the new velocity under the other forces (given in v_star for the
    prescribed nodes, whose inv_m is 0), the new velocity is
    v_i = v*_i + dt inv_m_i (D_i t_i - D_{i-1} t_{i-1}), and
    D_e = c_e t_e . (v_old,e+1 + v_e+1 - v_old,e - v_e) / 2
    is a symmetric, strictly diagonally dominant tridiagonal system in D, solved
    by the Thomas algorithm. Trapezoidal damping leaves central differences stable
    up to the undamped limit dt = 2 / omega_max whatever the damping."""
    ne = n - 1
    for i in range(n):
        if inv_m[i] != 0.0:
            for c in range(3):
                v_star[i, c] = vel_half[i, c] + dt * inv_m[i] * F[i, c]
    # one pass assembles row e and eliminates it against row e - 1 (Thomas); `inv_d`
    # keeps the reciprocal pivots, `up` the super-diagonal, `rhs` the reduced right side
    inv_d = tri[0]
    up = tri[2]
    rhs = tri[3]
    up_prev = 0.0
    rhs_prev = 0.0
    inv_prev = 0.0
    for e in range(ne):
        a = 0.5 * ca[e] * dt
        tx, ty, tz = tang[e, 0], tang[e, 1], tang[e, 2]
        dvx = vel_half[e + 1, 0] - vel_half[e, 0] + v_star[e + 1, 0] - v_star[e, 0]
        dvy = vel_half[e + 1, 1] - vel_half[e, 1] + v_star[e + 1, 1] - v_star[e, 1]
        dvz = vel_half[e + 1, 2] - vel_half[e, 2] + v_star[e + 1, 2] - v_star[e, 2]
        r = 0.5 * ca[e] * (tx * dvx + ty * dvy + tz * dvz)
        d = 1.0 + a * (inv_m[e] + inv_m[e + 1])
        u = 0.0
        if e < ne - 1:
            u = -a * inv_m[e + 1] * (tx * tang[e + 1, 0] + ty * tang[e + 1, 1] + tz * tang[e + 1, 2])
        if e > 0:
            low = -a * inv_m[e] * (tx * tang[e - 1, 0] + ty * tang[e - 1, 1] + tz * tang[e - 1, 2])
            w = low * inv_prev
            d -= w * up_prev
            r -= w * rhs_prev
        inv_prev = 1.0 / d
        up_prev = u
        rhs_prev = r
        inv_d[e] = inv_prev
        up[e] = u
        rhs[e] = r
    # back substitution, applying each D_e as it is found
    D_next = 0.0
    for e in range(ne - 1, -1, -1):
        D = (rhs[e] - up[e] * D_next) * inv_d[e]
        D_next = D
        tension[e] += D
        for c in range(3):
            f = D * tang[e, c]
            F[e, c] += f
            F[e + 1, c] -= f


@njit(cache=True, fastmath=FAST)
def run_steps(t0, dt, nsteps, rec_every, rec_phase, P, n, nh, pos, vel_half, acc_prev, mass, rest, ka, ca,
              kb, cb, wind_par, tow_t0, tow_dt, tow_tab, end_t0, end_dt, end_tab,
              reel_t0, reel_dt, reel_tab, reel, out_t, out_pos, out_vel, out_tension,
              out_reel, out_end_force, out_energy, out_mom, rec_start, extra_work, end_reaction):
    """Advance the leapfrog (velocity at half steps) up to `nsteps` steps.

    Velocity-dependent forces (bending and hinge damping, aerodynamics) use the
    velocity extrapolated to the full step, v(t) ~ v(t-dt/2) + a(t-dt) dt/2, which
    keeps the scheme second order for weak damping and exactly symplectic without
    it. The axial damping of the elements (and of the drogue link) is the one
    damping stiff enough to cut the stable step (by a third for a fuelled hose at
    300 N s); it acts instead on the mean of the old and new half-step velocities
    (trapezoidal, implicit), which costs one scalar tridiagonal solve along the
    chain (see `_implicit_axial_damping`) and leaves the step limited by the
    undamped axial mode alone.

    reel = [L_out, Ldot, exit tension, cumulative mass taken in, cumulative momentum
    carried across the reel exit (x, y, z), cumulative impulse of the hose on the tow
    point (x, y, z)]. out_mom records the free nodes' mass, node 0's mass and the free
    nodes' momentum at the half step, with the two cumulative sums, so a test can
    check the momentum balance to round-off. Returns (code, steps_done,
    records_done, bad_node).
    """
    F = np.zeros((n, 3))
    tension = np.zeros(n)
    vel = np.empty((n, 3))
    row = np.empty(6)
    tow_now = np.empty(6)
    tow_next = np.empty(6)
    end_now = np.empty(6)
    end_next = np.empty(6)
    reel_row = np.empty(2)
    work = extra_work
    rec = rec_start
    has_drogue = P[P_HAS_DROGUE] != 0.0
    last = n - 1
    mu = P[P_MU]
    # axial damping is applied implicitly below, so the force routine sees none
    ca_explicit = np.zeros_like(ca)
    inv_m = np.empty(n)
    inv_m[0] = 0.0
    for i in range(1, n):
        inv_m[i] = 1.0 / mass[i]
    v_star = np.empty((n, 3))
    tri = np.empty((4, n))
    for k in range(nsteps):
        t = t0 + k * dt
        # prescribed tow point (node 0): position and velocity at t and t+dt
        if k == 0:
            _interp_table(tow_t0, tow_dt, tow_tab, t, tow_now)
        else:
            for c in range(6):
                tow_now[c] = tow_next[c]
        _interp_table(tow_t0, tow_dt, tow_tab, t + dt, tow_next)
        for c in range(3):
            pos[0, c] = tow_now[c]
        end_active = P[P_END_MODE] != 0.0 and P[P_END_ON] <= t <= P[P_END_OFF]
        # rigid: the end node is the table; compliant: a spring-damper ties it to the table
        end_rigid = end_active and P[P_END_K] == 0.0
        if end_active:
            _interp_table(end_t0, end_dt, end_tab, t, end_now)
        if end_rigid:
            for c in range(3):
                pos[last, c] = end_now[c]
        # reel: hose length outside and the reel-exit element
        if P[P_REEL_MODE] == 1.0:
            _interp_table(reel_t0, reel_dt, reel_tab, t, reel_row)
            reel[0] = reel_row[0]
            reel[1] = reel_row[1]
        L = reel[0]
        r0 = L - P[P_HOSE_REST_SUM]
        if r0 > REMESH_MAX * P[P_L_NOM]:
            return REMESH_GROW, k, rec, -1
        if r0 < REMESH_MIN * P[P_L_NOM]:
            # below the band no merge is left when the hose is down to its fewest
            # elements; a shorter exit element would outrun the stable step
            if nh - 1 >= P[P_NE_MIN]:
                return REMESH_SHRINK, k, rec, -1
            return REEL_LIMIT, k, rec, -1
        m1_old = mass[1]
        rest[0] = r0
        ka[0] = P[P_EA0] / r0
        ca[0] = P[P_ETA_A0] / r0
        if nh > 1:
            lj = 0.5 * (r0 + rest[1])
            kb[1] = P[P_EI1] / lj
            cb[1] = P[P_ETA_B1] / lj
            mass[1] = 0.5 * mu * (r0 + rest[1]) + P[P_EXTRA_MASS0]
        else:
            mass[1] = 0.5 * mu * r0 + P[P_EXTRA_MASS0]
        # material entering node 1's lumped mass arrives at node 1's velocity: the
        # momentum it brings is the flux booked in reel[4:7]
        dm = mass[1] - m1_old
        # estimated full-step velocity
        for i in range(n):
            for c in range(3):
                vel[i, c] = vel_half[i, c] + 0.5 * dt * acc_prev[i, c]
        for c in range(3):
            vel[0, c] = tow_now[3 + c]
        if end_rigid:
            for c in range(3):
                vel[last, c] = end_now[3 + c]
        compute_forces(t, P, n, nh, pos, vel, mass, rest, ka, ca_explicit, kb, cb, wind_par,
                       F, tension, work)
        # the prescribed nodes' new half-step velocities, then the axial damping
        for c in range(3):
            v_star[0, c] = (tow_next[c] - tow_now[c]) / dt
        inv_m[1] = 1.0 / mass[1]      # the reel-exit node's mass follows the reel
        inv_m[last] = 1.0 / mass[last]
        if end_active and not end_rigid:
            for c in range(3):
                fc = P[P_END_K] * (end_now[c] - pos[last, c]) + P[P_END_C] * (end_now[3 + c] - vel[last, c])
                F[last, c] += fc
                end_reaction[c] = fc
                if end_reaction.shape[0] >= 6:
                    end_reaction[3 + c] += dt * fc
        if end_rigid:
            _interp_table(end_t0, end_dt, end_tab, t + dt, end_next)
            inv_m[last] = 0.0
            for c in range(3):
                v_star[last, c] = (end_next[c] - end_now[c]) / dt
        _implicit_axial_damping(dt, n, ca, work[0], vel_half, F, inv_m, v_star, tension, tri)
        # reel drum dynamics (Eq. 12) with the tension of the reel-exit element
        if P[P_REEL_MODE] == 2.0:
            R, I = drum_radius_inertia(P, L)
            if P[P_TORQUE_LAW] == 0.0:
                torque = P[P_TORQUE]
            else:
                torque = P[P_TORQUE] * R
            # payout angle phi, L' = R phi'; I phi'' = T_hose R - torque
            omega = reel[1] / R
            hold = _drive_hold(P, reel, dt) if P[P_REEL_HOLD] > 0.0 else 0.0
            omega += dt * ((tension[0] - hold) * R - torque) / I
            L_new = L + dt * R * omega
            if L_new > P[P_HOSE_TOTAL]:
                # the whole hose is out: the drum stops against its end stop
                L_new = P[P_HOSE_TOTAL]
                omega = 0.0
            reel[1] = R * omega
            reel[0] = L_new
        reel[2] = tension[0]
        reel[3] -= dm
        for c in range(3):
            reel[4 + c] += dm * vel_half[1, c]
            reel[7 + c] += dt * F[0, c]
        # kick
        for i in range(1, n):
            inv = 1.0 / mass[i] if i == last else inv_m[i]
            for c in range(3):
                a = F[i, c] * inv
                acc_prev[i, c] = a
                vel_half[i, c] += a * dt
        for c in range(3):
            vel_half[0, c] = (tow_next[c] - tow_now[c]) / dt
        if end_rigid:
            for c in range(3):
                v_new = (end_next[c] - end_now[c]) / dt
                # constraint reaction: what the prescribed motion needs beyond the forces
                end_reaction[c] = mass[last] * (v_new - vel_half[last, c]) / dt
                if end_reaction.shape[0] >= 6:
                    # a caller that gives room gets the impulse too (frame means)
                    end_reaction[3 + c] += dt * end_reaction[c]
                acc_prev[last, c] += end_reaction[c] / mass[last]
                vel_half[last, c] = v_new
        # record at time t with the synchronised velocity
        if (k + rec_phase) % rec_every == 0 and rec < out_t.shape[0]:
            out_t[rec] = t
            for i in range(n):
                for c in range(3):
                    vs = 0.5 * (vel_half[i, c] + (vel_half[i, c] - acc_prev[i, c] * dt))
                    if i == 0:
                        vs = tow_now[3 + c]
                    out_pos[rec, i, c] = pos[i, c]
                    out_vel[rec, i, c] = vs
            for e in range(n - 1):
                out_tension[rec, e] = tension[e]
            out_reel[rec, 0] = reel[0]
            out_reel[rec, 1] = reel[1]
            out_reel[rec, 2] = reel[2]
            for c in range(3):
                out_reel[rec, 3 + c] = F[0, c]
            for c in range(3):
                out_end_force[rec, c] = end_reaction[c] if end_active else 0.0
            ke = 0.0
            for i in range(1, n):
                v2 = 0.0
                for c in range(3):
                    v2 += out_vel[rec, i, c] ** 2
                ke += 0.5 * mass[i] * v2
            pe = potential_energy(P, n, nh, pos, rest, ka, kb)
            gpe = 0.0
            for i in range(1, n):
                gpe -= mass[i] * (P[P_GX] * pos[i, 0] + P[P_GY] * pos[i, 1] + P[P_GZ] * pos[i, 2])
            out_energy[rec, 0] = ke
            out_energy[rec, 1] = pe + gpe
            mfree = 0.0
            px = 0.0
            py = 0.0
            pz = 0.0
            for i in range(1, n):
                mfree += mass[i]
                px += mass[i] * vel_half[i, 0]
                py += mass[i] * vel_half[i, 1]
                pz += mass[i] * vel_half[i, 2]
            out_mom[rec, 0] = mfree
            out_mom[rec, 1] = 0.5 * mu * rest[0]
            out_mom[rec, 2] = px
            out_mom[rec, 3] = py
            out_mom[rec, 4] = pz
            for c in range(6):
                out_mom[rec, 5 + c] = reel[4 + c]
            rec += 1
        # drift, with the divergence checks on the new state
        for c in range(3):
            pos[0, c] = tow_next[c]
        v0x, v0y, v0z = vel_half[0, 0], vel_half[0, 1], vel_half[0, 2]
        vmax2 = P[P_VMAX] * P[P_VMAX]
        for i in range(1, n):
            if end_rigid and i == last:
                for c in range(3):
                    pos[i, c] = end_next[c]
            else:
                for c in range(3):
                    pos[i, c] += vel_half[i, c] * dt
            s2 = (vel_half[i, 0] - v0x) ** 2 + (vel_half[i, 1] - v0y) ** 2 + (vel_half[i, 2] - v0z) ** 2
            if not (s2 <= vmax2):    # also true for NaN
                if not math.isfinite(s2):
                    return NONFINITE, k + 1, rec, i
                return OVERSPEED, k + 1, rec, i
            if not (math.isfinite(pos[i, 0]) and math.isfinite(pos[i, 1]) and math.isfinite(pos[i, 2])):
                return NONFINITE, k + 1, rec, i
    return OK, nsteps, rec, -1
