"""Leapfrog time stepping of the node chain (`run_steps`) and what it needs
besides the forces: table interpolation, the reel drum and its drive hold-back,
the implicit axial damping."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from solver.kernel.forces import FAST, compute_forces, potential_energy
from solver.kernel.layout import *  # noqa: F403 (the layout's indices are the kernel's vocabulary)


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
    tow_now = np.empty(6)
    tow_next = np.empty(6)
    end_now = np.empty(6)
    end_next = np.empty(6)
    reel_row = np.empty(2)
    work = extra_work
    rec = rec_start
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
