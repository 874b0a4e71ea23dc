"""Forces on the node chain (gravity, axial, bending, hinge, clamp, hose and
drogue aerodynamics) and its potential energy, compiled."""
from __future__ import annotations

import math

from numba import njit

from solver.kernel.layout import *  # noqa: F403 (the layout's indices are the kernel's vocabulary)
from solver.wind import wind_eval


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
