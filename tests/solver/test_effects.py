"""The unmodelled-effect library (`solver.effects`, `solver.wind`): each model
against a known answer, and what it does to the hose."""
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import signal
from scipy.integrate import trapezoid

from solver import kernel as K
from solver import wind as W
from solver.atmosphere import isa, kcas_to_tas
from solver.drogue import DrogueProperties
from solver.effects import (EFFECTS, EffectContext, EffectError, TankerGeometry, apply_effects,
                            bow_wave_params, mil_hdbk_1797_sigma, tanker_wake_params, validate_effects)
from solver.hose import HoseProperties
from solver.integrate import simulate
from solver.model import Model
from solver.reel import ReelProperties
from solver.statics import solve_static

G = 9.80665
KDC10 = TankerGeometry(wing_span=50.41, tow_point_aft_of_cg=4.0, tow_point_below_wing_root=1.3,
                       tow_point_span_station=16.5)


def kdc10_model(n=20, cl=0.0, wind=None, reel=None, gravity=(0.0, 0.0, -G)):
    """The KDC-10 pod hose and drogue (data-sheet values) at engagement 7's condition."""
    st = isa(15050 * 0.3048)
    u = kcas_to_tas(254.0, 15050.0)
    hose = HoseProperties(length=75 * 0.3048, outer_diameter=0.0635, inner_diameter=0.0445,
                          dry_mass_per_length=2.2, EI=50.0, EA=2.0e6, bending_damping=2.0,
                          axial_damping=300.0, total_length=75 * 0.3048 + 5.0 if reel else None)
    drogue = DrogueProperties(mass=27.0, diameter=0.68, cd=0.82, cl=cl, cp_aft_of_hinge=0.40)
    return Model(hose, n, st.density, st.kinematic_viscosity,
                 wind=wind if wind is not None else W.freestream(u), drogue=drogue,
                 reel=reel if reel is not None else ReelProperties(), gravity=gravity)


def context(m, **kw):
    return EffectContext(true_airspeed=m.wind.mean_speed, air_density=m.air_density,
                         altitude_m=15050 * 0.3048, duration_s=kw.pop("duration_s", 10.0), tanker=KDC10,
                         gross_weight_kg=410000 * 0.45359237, **kw)


# ---- registry ---------------------------------------------------------------------------

def test_every_effect_is_documented_with_units_ranges_and_defaults_inside_them():
    for name, e in EFFECTS.items():
        assert e.model and e.source and e.title, name
        assert e.params, name
        for key, p in e.params.items():
            assert p.unit and p.doc, (name, key)
            assert p.lo <= p.default <= p.hi, (name, key)
            assert p.check(p.default) is None
        assert e.comparison_only == (e.apply is None), name


def test_every_effect_parameter_carries_its_calibration_metadata_inside_its_physical_range():
    # the registry is the only place the diagnosis and the validation cases read
    # search ranges, probes and off values from: each must be complete and coherent
    for name, e in EFFECTS.items():
        assert bool(e.calibrated) != bool(e.not_calibrated), \
            f"{name}: calibrated parameters or a reason why none, not both"
        for key, p in e.params.items():
            assert p.off is not None and p.check(p.off) is None, (name, key, p.off)
            if p.search is None:
                assert p.probe is None and not p.log, (name, key)
                continue
            s0, s1 = p.search
            assert p.lo <= s0 < s1 <= p.hi, (name, key, p.search)
            assert s0 <= p.off <= s1, (name, key, "off value outside the search range")
            assert s0 <= p.probe <= s1 and p.probe != p.off, (name, key, p.probe)
            assert not p.log or s0 > 0.0, (name, key, "a logarithmic search needs a positive range")


@pytest.mark.parametrize("request_, pattern", [
    ({"tanker_wak": {}}, r"effect tanker_wak: unknown effect"),
    ({"tanker_wake": {"strenght": 1.0}}, r"effect tanker_wake.strenght: unknown parameter"),
    ({"tanker_wake": {"strength": 3.5}}, r"effect tanker_wake.strength: must lie in 0..3, got 3.5"),
    ({"turbulence": {"seed": 1.5}}, r"turbulence.seed: must be an integer"),
    ({"gust": {"length_m": float("nan")}}, r"gust.length_m: must be finite"),
    ({"drogue_lift": {"scale": True}}, r"drogue_lift.scale: must be a number"),
])
def test_bad_requests_name_the_effect_and_key(request_, pattern):
    with pytest.raises(EffectError, match=pattern):
        validate_effects(request_)


def test_effects_compose_in_any_order_of_request():
    m = kdc10_model()
    ctx = context(m, duration_s=2.0)
    a = apply_effects(m, {"gust": {}, "steady_wind": {"vertical_mps": 1.0}, "drogue_drag": {"scale": 1.1}}, ctx)
    b = apply_effects(apply_effects(m, {"drogue_drag": {"scale": 1.1}}, ctx),
                      {"steady_wind": {"vertical_mps": 1.0}, "gust": {}}, ctx)
    assert np.array_equal(a.wind.params, b.wind.params)
    assert a.drogue == b.drogue
    pts = np.array([[10.0, 0.0, -2.0]])
    U = m.wind.mean_speed
    t_crest = 2.0 + (100.0 + 10.0) / U        # the default gust's crest (xi = d_m) at x = 10 m
    assert_allclose(a.wind.velocity(t_crest, pts), [[U, 0.0, 1.0 + 3.0]])


def test_no_effects_leave_the_model_alone_and_defaults_fill_in():
    m = kdc10_model()
    assert apply_effects(m, {}, context(m)) is m
    assert validate_effects({"tanker_wake": {}})["tanker_wake"]["strength"] == 1.0
    # comparison-only effects do not touch the physics
    assert apply_effects(m, {"sensor_lag": {"delay_s": 0.2}}, context(m)) is m
    assert apply_effects(m, {"drogue_reference": {"offset_m": 0.3}}, context(m)) is m


# ---- tanker wake: vortex filaments ------------------------------------------------------

def single_segment_field(a, b, gamma, core=0.0):
    par = W.vortex_wake(np.array([[*a, *b, gamma]]), np.zeros((0, 4)), core)
    return W.WindField([(W.VORTEX_WAKE, par)])


def test_vortex_segment_matches_biot_savart_closed_form():
    # Katz & Plotkin Eq. 2.68 in angle form: |v| = Gamma/(4 pi h) (cos t1 - cos t2),
    # direction (b - a) x (p - a), right-handed about a->b. Same physics, different
    # algebra: agreement to round-off (1e-12 of the magnitude).
    rng = np.random.default_rng(3)
    a, b, gam = np.array([1.0, -2.0, 0.5]), np.array([4.0, 3.0, -1.0]), 37.0
    f = single_segment_field(a, b, gam)
    e = (b - a) / np.linalg.norm(b - a)
    for p in rng.uniform(-8, 8, size=(50, 3)):
        r1, r2 = p - a, p - b
        h_vec = np.cross(e, r1)
        h = np.linalg.norm(h_vec)
        c1 = e @ r1 / np.linalg.norm(r1)
        c2 = e @ r2 / np.linalg.norm(r2)
        v_ref = gam / (4 * np.pi * h) * (c1 - c2) * h_vec / h
        assert_allclose(f.velocity(0.0, p)[0], v_ref, rtol=1e-12, atol=1e-12 * np.linalg.norm(v_ref))


def test_hallock_burnham_core_and_semi_infinite_filament():
    # A segment 2e6 m long seen from its middle is an infinite line to 1e-12; with
    # a core r_c the swirl is Gamma h / (2 pi (h^2 + r_c^2)) (Hallock & Burnham).
    gam, rc = 100.0, 0.8
    f = single_segment_field([0, -1e6, 0], [0, 1e6, 0], gam, core=rc)
    for h in (0.1, 0.8, 3.0):
        v = f.velocity(0.0, [[0.0, 0.0, -h]])[0]     # below a +y vortex: swirl toward -x
        assert_allclose(v, [-gam * h / (2 * np.pi * (h * h + rc * rc)), 0, 0], rtol=1e-9)
    # a filament from a to x = +inf: the far-end limit of the segment; at its own
    # start plane exactly half the infinite line's swirl
    semi = W.WindField([(W.VORTEX_WAKE, W.vortex_wake(np.zeros((0, 7)), np.array([[2.0, 0.0, 0.0, gam]]), 0.0))])
    long_seg = single_segment_field([2.0, 0, 0], [2.0 + 1e7, 0, 0], gam)
    p = np.array([[5.0, 1.0, -2.0], [2.0, 0.0, 3.0], [-30.0, 4.0, 1.0]])
    assert_allclose(semi.velocity(0, p), long_seg.velocity(0, p), rtol=1e-6, atol=1e-12)
    assert_allclose(semi.velocity(0, [[2.0, 0.0, 3.0]])[0], [0, -gam / (4 * np.pi * 3.0), 0], rtol=1e-12)


def wing(n_panels=80, span=50.0, lift=1.0e6, rho=1.0, V=100.0):
    fin, semi, g0 = W.elliptic_lifting_line(lift, rho, V, span, 0.0, 0.0, 0.0, n_panels)
    return W.WindField([(W.VORTEX_WAKE, W.vortex_wake(fin, semi, 0.0))]), semi, g0


def test_far_wake_downwash_is_two_cl_over_pi_ar():
    # Prandtl: the elliptically loaded wing's wake sheet moves down at
    # w = 2 C_L V / (pi AR) = Gamma0 / b across the whole span far behind the wing,
    # and half that at the lifting line. On the sheet midway between two trailing
    # filaments next to the centre line the error is the discretisation of the
    # loading, O(1/N^2): 2.6e-4 at N = 80 (1.1e-3 at N = 40, 6.5e-5 at N = 160).
    # Tolerance 1e-3. (Off the sheet the Trefftz-plane test below checks the
    # whole span.)
    span, lift, rho, V = 50.0, 1.0e6, 1.0, 100.0
    f, semi, g0 = wing(span=span, lift=lift, rho=rho, V=V)
    S = 200.0                                  # any wing area: C_L / AR does not depend on it
    CL = lift / (0.5 * rho * V * V * S)
    AR = span ** 2 / S
    w_far = 2 * CL * V / (np.pi * AR)
    assert g0 / span == pytest.approx(w_far, rel=1e-12)
    y = semi[:, 1]
    mid = np.array([0.5 * (y[40] + y[41])])  # between the two filaments next to the centre line
    far = f.velocity(0, np.column_stack([np.full_like(mid, 1e7), mid, np.zeros_like(mid)]))
    at_line = f.velocity(0, np.column_stack([np.zeros_like(mid), mid, np.zeros_like(mid)]))
    assert_allclose(-far[:, 2], w_far, rtol=1e-3)
    assert_allclose(-at_line[:, 2], 0.5 * w_far, rtol=1e-3)


def test_far_wake_off_the_sheet_matches_the_trefftz_plane_closed_form():
    # Far behind the wing the elliptic sheet is a flat plate of half span s moving
    # down at w0 = Gamma0 / b (Trefftz plane); its complex velocity is
    # u_y - i u_z = i w0 (1 - zeta / sqrt(zeta^2 - s^2)), zeta = y + i z. Off the sheet
    # the discrete filaments converge as 1/N^2: 4.7e-4 w0 at N = 80 for points
    # 1.3 m or more from the sheet (1.9e-3 at N = 40). Tolerance 1e-3 w0.
    s = 25.0
    zeta = np.array([0 + 3j, 10 - 2j, 16.5 - 1.3j, 16.5 - 5j, 30 + 0j, -20 - 8j, 5 - 10j])
    errs = {}
    for n in (40, 80):
        f, _, g0 = wing(n_panels=n)
        w0 = g0 / (2 * s)
        cv = 1j * w0 * (1 - zeta / (np.sqrt(zeta - s) * np.sqrt(zeta + s)))
        v = f.velocity(0, np.column_stack([np.full(len(zeta), 1e7), zeta.real, zeta.imag]))
        errs[n] = np.max(np.hypot(v[:, 1] - cv.real, v[:, 2] + cv.imag)) / w0
    assert errs[80] < 1e-3
    assert errs[40] / errs[80] > 3.0          # second-order convergence: discretisation, not model error


def test_equivalent_horseshoe_gives_eight_over_pi_squared_of_the_elliptic_downwash():
    # The single horseshoe carrying the same lift with span pi b / 4 (so Gamma =
    # Gamma0) has far-wake centre-line downwash 2 Gamma / (pi b') from its two legs
    # (Anderson Sec. 5.3.1): 8/pi^2 = 0.81 of the elliptic value. Exact (the
    # segment routine is exact), hence the library's 80-panel lifting line rather
    # than one horseshoe: the hose hangs inboard of the tip, where the horseshoe's
    # concentrated legs are worst.
    b, g0 = 50.0, 100.0
    bp = np.pi * b / 4
    L = 1e9
    fin = np.array([[0, -bp / 2, 0, 0, bp / 2, 0, g0]])
    semi = np.array([[0, -bp / 2, 0, -g0], [0, bp / 2, 0, g0]])
    f = W.WindField([(W.VORTEX_WAKE, W.vortex_wake(fin, semi, 0.0))])
    w = -f.velocity(0, [[L, 0.0, 0.0]])[0, 2]
    assert w == pytest.approx(2 * g0 / (np.pi * bp), rel=1e-9)
    assert w == pytest.approx(8 / np.pi ** 2 * g0 / b, rel=1e-9)


def test_wake_grid_matches_the_filament_sums_around_the_hose():
    # The kernel interpolates the steady wake trilinearly on a grid of spacing h;
    # the error is at most h^2/8 |d2v/dx2| per direction. Below the tow point the
    # field's shortest length is the sheet's height above it (1.3 m), so the
    # bound is h^2 / (8 (1.3 m)^2) of |v| (1.8 % at h = 0.49 m); the fuselage wake
    # is off (16.5 m outboard it is nil) so the filaments set the scale.
    m = kdc10_model()
    ctx = context(m)
    p = validate_effects({"tanker_wake": {"fuselage_drag_area_m2": 0.0}})["tanker_wake"]
    grid = W.WindField([(W.VORTEX_WAKE, tanker_wake_params(m, p, ctx, grid=True))])
    direct = W.WindField([(W.VORTEX_WAKE, tanker_wake_params(m, p, ctx, grid=False))])
    h = grid.params[3 + W.VW_GRID + 3]
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(-1, 24, 3000), rng.uniform(-4, 4, 3000), rng.uniform(-10, 0.0, 3000)])
    vg, vd = grid.velocity(0, pts), direct.velocity(0, pts)
    rel = np.linalg.norm(vg - vd, axis=1) / np.linalg.norm(vd, axis=1)
    assert np.max(rel) < h * h / (8 * 1.3 ** 2)
    # outside the grid the sums answer directly
    far = np.array([[200.0, 80.0, -150.0]])
    assert_allclose(grid.velocity(0, far), direct.velocity(0, far), rtol=1e-12)


def test_wake_grid_is_shared_by_every_strength_and_adds_the_fuselage_wake_exactly():
    # The grid holds the filaments, linear in circulation, at unit circulation per
    # geometry: a second strength reuses it scaled, and answers as a grid built
    # from scratch does (to round-off); the fuselage wake is added exactly, so
    # far outside the vortex sheet the grid answers like the direct sums.
    m = kdc10_model()
    ctx = context(m)
    p1 = validate_effects({"tanker_wake": {"strength": 1.0}})["tanker_wake"]
    p2 = dict(p1, strength=1.7)
    W._GRID_CACHE.clear()
    w1 = W.WindField([(W.VORTEX_WAKE, tanker_wake_params(m, p1, ctx))])
    w2 = W.WindField([(W.VORTEX_WAKE, tanker_wake_params(m, p2, ctx))])
    assert len(W._GRID_CACHE) == 1
    W._GRID_CACHE.clear()
    w2_cold = W.WindField([(W.VORTEX_WAKE, tanker_wake_params(m, p2, ctx))])
    rng = np.random.default_rng(1)
    pts = np.column_stack([rng.uniform(-1, 24, 500), rng.uniform(-4, 4, 500), rng.uniform(-10, 0.0, 500)])
    assert_allclose(w2.velocity(0, pts), w2_cold.velocity(0, pts), rtol=1e-12, atol=1e-12)
    # on the centre line behind the fuselage the deficit is the fuselage's alone
    # (no filament there is strong): grid and direct sums agree to the filaments'
    # interpolation bound of the test above
    direct = W.WindField([(W.VORTEX_WAKE, tanker_wake_params(m, p2, ctx, grid=False))])
    assert_allclose(w2.velocity(0, pts), direct.velocity(0, pts), rtol=0.02, atol=0.02)
    assert not np.allclose(w1.velocity(0, pts), w2.velocity(0, pts))


def test_fuselage_wake_carries_the_fuselage_drag_as_momentum_deficit():
    # Momentum balance behind a body of drag D = q C_D A in a stream U: the
    # linearised deficit integrates to U C_D A / 2 over any cross plane, at every
    # distance (the self-similar profile only redistributes it). Quadrature on a
    # 0.02 m grid over +-5 half-widths: error < 1e-4.
    U, cda = 150.0, 0.6
    fus = W.FuselageWake(drag_area=cda, x_origin=0.0, y_axis=1.0, z_axis=-2.0, U=U, r0=1.4)
    f = W.WindField([(W.VORTEX_WAKE, W.vortex_wake(np.zeros((0, 7)), np.zeros((0, 4)), 0.0, fuselage=fus))])
    g = np.arange(-8.0, 8.0, 0.02)
    Y, Z = np.meshgrid(g + 1.0, g - 2.0, indexing="ij")
    for x in (0.5, 10.0, 40.0):
        pts = np.column_stack([np.full(Y.size, x), Y.ravel(), Z.ravel()])
        deficit = -f.velocity(0, pts)[:, 0].sum() * 0.02 ** 2
        assert deficit == pytest.approx(U * cda / 2, rel=1e-4)
    # and nothing ahead of the origin
    assert f.velocity(0, [[-1.0, 1.0, -2.0]])[0, 0] == 0.0


def test_tanker_wake_moves_the_kdc10_drogue_down_and_outboard():
    # Inboard of the right wing tip the wake sheet moves down (downwash) and, below
    # the sheet, outboard (sidewash): the drogue trails lower and to starboard,
    # and the heavier tanker (engagements 8, 9: 575 000 lb) moves it further.
    m = kdc10_model()
    base = solve_static(m).pos[-1]
    light = solve_static(apply_effects(m, {"tanker_wake": {}}, context(m))).pos[-1]
    heavy_ctx = EffectContext(m.wind.mean_speed, m.air_density, tanker=KDC10, gross_weight_kg=575000 * 0.45359237)
    heavy = solve_static(apply_effects(m, {"tanker_wake": {}}, heavy_ctx)).pos[-1]
    d1, d2 = light - base, heavy - base
    assert d1[2] < -0.3 and d1[1] > 0.3
    assert d2[2] < d1[2] and d2[1] > d1[1]
    # circulation scales with weight: the shift grows nearly in proportion
    assert d2[1] / d1[1] == pytest.approx(575 / 410, rel=0.1)


# ---- turbulence -------------------------------------------------------------------------

@pytest.mark.parametrize("component,length", [("u", 533.4), ("v", 266.7), ("w", 266.7)])
def test_dryden_series_has_the_dryden_spectrum_and_intensity(component, length):
    # 2^21 samples 1/8 of a scale length apart (X = 2.6e5 L of record).
    # Intensity: the variance estimate of a process with correlation length L over
    # X has relative standard deviation sqrt(2 L / X) (3 ms-scale: 0.28 %); within
    # 4 of those (1.1 %) on sigma^2, i.e. 0.6 % on sigma.
    # Spectrum: Welch with 512-sample Hann segments (8191 averaged at 50 % overlap,
    # relative standard deviation ~ 1/sqrt(8191 * 0.5) = 1.6 % per bin), averaged
    # over 8-bin bands: 0.6 % per band; tolerance 4 sigma = 2.5 %, from 8 bins up
    # (Hann leakage at the spectrum's knee stays below 1 % there) to a quarter of
    # Nyquist. The samples are the exact process sampled, whose spectrum is the
    # Dryden spectrum aliased: sum over k of Phi(f + k fs), summed to |k| = 400
    # (the rest < 1e-4).
    sigma, n = 1.7, 2 ** 21
    dx = length / 8
    y = W.dryden_series(component, sigma, length, dx, n, np.random.default_rng(11))
    assert np.std(y) == pytest.approx(sigma, rel=0.006)
    f, pxx = signal.welch(y, fs=1.0 / dx, nperseg=512)      # f in cycles/m, one-sided
    fs = 1.0 / dx
    ks = np.arange(-400, 401)[:, None]
    analytic = 2 * np.pi * W.dryden_psd(component, sigma, length, 2 * np.pi * np.abs(f[None, :] + ks * fs)).sum(0)
    sel = slice(8, 8 + 8 * 7)
    ratio = pxx[sel].reshape(-1, 8).mean(axis=1) / analytic[sel].reshape(-1, 8).mean(axis=1)
    assert_allclose(ratio, 1.0, atol=0.025)


def test_dryden_psd_integrates_to_the_variance():
    om = np.linspace(0, 2000.0, 2_000_001)
    for c in "uvw":
        # the tail beyond 2000 / L holds 1/(pi 2000 L/L) of the variance (< 2e-4)
        assert trapezoid(W.dryden_psd(c, 2.0, 1.0, om), om) == pytest.approx(4.0, rel=5e-4)
    assert mil_hdbk_1797_sigma(15000 * 0.3048, "light") == pytest.approx(4.6 * 0.3048)
    assert mil_hdbk_1797_sigma(15000 * 0.3048, "severe") == pytest.approx(22.1 * 0.3048)


def test_turbulence_is_frozen_convected_and_seeded():
    m = kdc10_model()
    ctx = context(m, duration_s=5.0)
    a = apply_effects(m, {"turbulence": {"seed": 4}}, ctx)
    b = apply_effects(m, {"turbulence": {"seed": 4}}, ctx)
    c = apply_effects(m, {"turbulence": {"seed": 5}}, ctx)
    assert np.array_equal(a.wind.params, b.wind.params)
    assert not np.array_equal(a.wind.params, c.wind.params)
    U = m.wind.mean_speed
    pts = np.array([[0.0, 0, 0], [5.0, 0, -1], [20.0, 1, -3]])
    gust = a.wind.velocity(1.0, pts) - [U, 0, 0]
    # Taylor: the air at x at time t is at x + U dt at t + dt (exactly, for table
    # points; 1e-9 covers the interpolation's round-off)
    assert_allclose(a.wind.velocity(1.0 + 0.1, pts + [U * 0.1, 0, 0]) - [U, 0, 0], gust, atol=1e-9)
    assert 0.1 < np.max(np.abs(gust)) < 10.0


# ---- bow wave ---------------------------------------------------------------------------

def test_moving_source_is_a_rankine_half_body():
    # Source of Q = pi R^2 U at s(t): velocity Q r / (4 pi |r|^3) (Anderson Sec. 6.5);
    # with the free stream the stagnation point sits sqrt(Q / (4 pi U)) = R/2
    # upstream and the body's radius far downstream is R (continuity: Q = pi R^2 U).
    U, R = 150.0, 1.0
    Q = np.pi * R * R * U
    a = R / 2
    path = np.array([[10.0, 1.0, -2.0], [4.0, 1.0, -2.0]])     # sampled at t = 0 and 1 s
    f = W.freestream(U).plus(W.MOVING_SOURCE, W.moving_source(Q, a, 0.0, 1.0, path))
    src = np.array([7.0, 1.0, -2.0])                            # at t = 0.5 s
    rng = np.random.default_rng(2)
    for p in src + rng.uniform(-6, 6, size=(20, 3)):
        r = p - src
        if np.linalg.norm(r) < a:
            continue
        assert_allclose(f.velocity(0.5, p)[0] - [U, 0, 0], Q * r / (4 * np.pi * np.linalg.norm(r) ** 3),
                        rtol=1e-12)
    assert_allclose(f.velocity(0.5, src - [a, 0, 0])[0], 0.0, atol=1e-9)
    # far downstream the body (radius R) displaces exactly the source's flux
    x_far = 1e4
    assert f.velocity(0.5, src + [x_far, 0, 0])[0, 0] - U == pytest.approx(Q / (4 * np.pi * x_far ** 2))


def test_drogue_is_pushed_away_as_the_probe_nears():
    # The receiver closes from 10 m at 2 m/s to contact at 5 s. Ahead of the nose
    # the source field points away from it (and against the free stream): the
    # drogue moves away from the nose, more the nearer the probe. The default
    # nose sits below and to port of the probe (F/A-18E/F): mostly to starboard.
    m = kdc10_model(n=16)
    ctx = context(m, duration_s=5.0)
    par = bow_wave_params(m, validate_effects({"bow_wave": {}})["bow_wave"], ctx)
    mb = apply_effects(m, {"bow_wave": {"closure_rate_mps": 2.0, "start_gap_m": 10.0}}, ctx)
    s0 = solve_static(m)
    res = simulate(mb, 5.0, solve_static(mb), record_dt=0.1)
    d = res.drogue_xyz - s0.pos[-1]
    n = int(par[4])
    src = par[5:5 + 3 * n].reshape(n, 3)[np.round((res.t - par[2]) / par[3]).astype(int)]
    away = src - s0.pos[-1]
    away = -away / np.linalg.norm(away, axis=1)[:, None]
    outward = np.sum(d * away, axis=1)
    gap = 10.0 - 2.0 * res.t
    assert np.all(np.diff(outward[gap > 1.0]) > 0)        # away from the nose, more as it nears
    assert outward[gap > 8.0].max() < 0.01 and outward[-1] > 0.2
    assert d[-1, 1] > 0.3
    # a nose straight behind the drogue: less drag, the drogue falls back toward the tanker and drops
    mc = apply_effects(m, {"bow_wave": {"nose_y_m": 0.0, "nose_z_m": 0.0}}, ctx)
    dc = simulate(mc, 5.0, solve_static(mc), record_dt=0.1).drogue_xyz[-1] - s0.pos[-1]
    assert dc[0] < -0.05 and dc[2] < -0.3 and abs(dc[1]) < 1e-9


# ---- gust -------------------------------------------------------------------------------

def test_one_minus_cosine_gust_shape_and_convection():
    # MIL-HDBK-1797: v = Vm/2 (1 - cos(pi xi / dm)) on 0 <= xi <= dm, Vm beyond
    # (ramp), or back to zero over another dm (full wave); xi = U (t - t0) - x.
    U, t0, dm, Vm = 150.0, 1.0, 60.0, 3.0
    ramp = W.WindField([(W.ONE_MINUS_COSINE, W.one_minus_cosine(U, t0, dm, False, [0, 0, Vm]))])
    wave = W.WindField([(W.ONE_MINUS_COSINE, W.one_minus_cosine(U, t0, dm, True, [0, 0, Vm]))])
    t = np.linspace(0, 3, 301)
    x = 12.0
    xi = U * (t - t0) - x
    ref = np.where(xi <= 0, 0.0, np.where(xi >= dm, Vm, 0.5 * Vm * (1 - np.cos(np.pi * xi / dm))))
    ref_w = np.where((xi <= 0) | (xi >= 2 * dm), 0.0, 0.5 * Vm * (1 - np.cos(np.pi * xi / dm)))
    got = np.array([ramp.velocity(tt, [[x, 0, -2]])[0, 2] for tt in t])
    got_w = np.array([wave.velocity(tt, [[x, 0, -2]])[0, 2] for tt in t])
    assert_allclose(got, ref, atol=1e-12)
    assert_allclose(got_w, ref_w, atol=1e-12)
    assert got_w.max() == pytest.approx(Vm, rel=1e-3)


def test_vertical_gust_lifts_the_drogue_then_lets_it_return():
    m = kdc10_model(n=16)
    mg = apply_effects(m, {"gust": {"vertical_mps": 3.0, "length_m": 80.0, "start_s": 0.5}}, context(m))
    s0 = solve_static(m)
    res = simulate(mg, 4.0, s0, record_dt=0.02)
    dz = res.drogue_xyz[:, 2] - s0.pos[-1, 2]
    # an up-gust rotates the relative wind up by 3/163 rad: about 0.4 m at the drogue
    assert dz.max() > 0.15
    assert abs(dz[res.t < 0.5]).max() < 1e-4         # nothing before the front arrives
    assert abs(dz[-1]) < 0.5 * dz.max()


# ---- steady wind ------------------------------------------------------------------------

def rotation_y(angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


@pytest.mark.parametrize("vertical,lateral", [(4.0, 0.0), (0.0, -5.0)])
def test_steady_wind_turns_the_trail_like_a_rotated_free_stream(vertical, lateral):
    # Without drogue lift the model is invariant under rotation (drag along the
    # relative wind, Eq. 7 regimes on its normal component): the trail in the wind
    # (U, lateral, vertical) is the trail in a free stream of the same speed along
    # +x with gravity turned the other way, turned back. Both statics converge to
    # 1e-7 of the load; positions agree to 1e-5 m.
    m = kdc10_model(n=20)
    U = m.wind.mean_speed
    mw = apply_effects(m, {"steady_wind": {"vertical_mps": vertical, "lateral_mps": lateral}}, context(m))
    v = np.array([U, lateral, vertical])
    V = np.linalg.norm(v)
    # rotation taking +x to the wind direction
    e = v / V
    k = np.cross([1.0, 0, 0], e)
    s, c = np.linalg.norm(k), e[0]
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    Rm = np.eye(3) + kx + kx @ kx * (1 - c) / s ** 2
    mr = kdc10_model(n=20, wind=W.freestream(V), gravity=tuple(Rm.T @ np.array([0, 0, -G])))
    pw = solve_static(mw).pos
    pr = solve_static(mr).pos @ Rm.T
    assert_allclose(pw, pr, atol=1e-5)
    base = solve_static(m).pos[-1]
    if vertical:
        assert pw[-1, 2] > base[2] + 0.3      # updraft: the drogue rises
    else:
        assert pw[-1, 1] < base[1] - 0.3      # wind to port: the drogue goes to port


# ---- drogue, hose and reel properties ---------------------------------------------------

def aero_on_straight_chain(m, direction):
    """Kernel forces (no gravity) on a straight chain along `direction` at rest."""
    nh = m.n_elements
    rest = np.full(nh, m.element_length)
    n, mass, rest_all, ka, ca, kb, cb = m.build_arrays(nh, rest)
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    pos = np.vstack([np.outer(np.cumsum(np.r_[0.0, rest_all]), d)])
    F = np.zeros((n, 3))
    K.compute_forces(0.0, m.params(nh, rest), n, nh, pos, np.zeros_like(pos), mass, rest_all, ka, ca, kb,
                     cb, m.wind.params, F, np.zeros(n), np.zeros((6, n, 3)))
    return F


def test_drogue_scales_multiply_the_wind_tunnel_forces():
    # Eq. 10-11 on a drogue trailing straight into the wind: drag q C_D A along the
    # wind, lift q C_L A up, each times its in-flight scale. Internal forces cancel
    # in the sum over the nodes, gravity is off and the hose's own drag is scaled
    # to 1e-9 of itself (< 1e-8 N): the sum is the drogue's force (exact).
    m0 = kdc10_model(n=4, cl=0.18)
    m = Model(m0.hose, 4, m0.air_density, m0.kinematic_viscosity, wind=m0.wind, drogue=m0.drogue,
              gravity=(0.0, 0.0, 0.0), hose_drag_scale=1e-9)
    me = apply_effects(m, {"drogue_lift": {"scale": 0.4}, "drogue_drag": {"scale": 1.3}}, context(m))
    q = 0.5 * m.air_density * m.wind.mean_speed ** 2
    A = np.pi * 0.68 ** 2 / 4
    for model, sl, sd in ((m, 1.0, 1.0), (me, 0.4, 1.3)):
        f = aero_on_straight_chain(model, [1, 0, 0]).sum(axis=0)
        assert_allclose(f, [q * 0.82 * sd * A, 0.0, q * 0.18 * sl * A], rtol=1e-9, atol=1e-6)


def test_hose_drag_scales_crossflow_and_friction_separately():
    # An element at angle a to the wind: normal force 1/2 rho C_Dn D l (V sin a)^2
    # (Eq. 7 regime for its Reynolds number) and axial 1/2 rho C_a pi D l (V cos a)^2;
    # the effect multiplies each by its own factor (exact).
    m = kdc10_model(n=4)
    m = Model(m.hose, m.n_elements, m.air_density, m.kinematic_viscosity, wind=m.wind, gravity=(0.0, 0.0, 0.0))
    me = apply_effects(m, {"hose_drag": {"crossflow": 1.7, "friction": 0.5}}, context(m))
    d = np.array([math.cos(0.3), 0.0, -math.sin(0.3)])
    f0 = aero_on_straight_chain(m, d).sum(axis=0)
    f1 = aero_on_straight_chain(me, d).sum(axis=0)
    tang = d
    axial0, axial1 = f0 @ tang, f1 @ tang
    assert axial1 == pytest.approx(0.5 * axial0, rel=1e-9)
    assert_allclose(f1 - axial1 * tang, 1.7 * (f0 - axial0 * tang), rtol=1e-9)


def test_hose_stiffness_scales_stretch_and_sag():
    # Hanging straight down in still air, element e carries the weight below it,
    # so the stretch is sum(W_e l / EA): exactly 1/axial of the baseline. A short
    # horizontal cantilever under its own weight sags as 1/EI (linear beam):
    # 1/bending to within its geometric nonlinearity (sag/length 2e-4: 1e-4).
    hose = HoseProperties(length=10.0, outer_diameter=0.05, inner_diameter=0.0, dry_mass_per_length=2.0,
                          EI=50.0, EA=2e5)
    from solver.model import Clamp
    hang = Model(hose, 10, 0.0, 1.5e-5)
    ctx = EffectContext(1.0, 1.0)
    down = np.array([0.0, 0.0, -1.0])
    from tests.solver.helpers import straight_state
    g = straight_state(10, 10.0, direction=down).pos
    z1 = solve_static(hang, guess=g).pos[-1, 2]
    z2 = solve_static(apply_effects(hang, {"hose_stiffness": {"axial": 2.0}}, ctx), guess=g).pos[-1, 2]
    assert (z2 + 10.0) / (z1 + 10.0) == pytest.approx(0.5, rel=1e-6)
    stiff = HoseProperties(length=1.0, outer_diameter=0.05, inner_diameter=0.0, dry_mass_per_length=0.2,
                           EI=50.0, EA=1e7)
    cant = Model(stiff, 10, 0.0, 1.5e-5, clamp=Clamp())
    gc = straight_state(10, 1.0).pos
    s1 = solve_static(cant, guess=gc).pos[-1, 2]
    s2 = solve_static(apply_effects(cant, {"hose_stiffness": {"bending": 4.0}}, ctx), guess=gc).pos[-1, 2]
    assert s2 / s1 == pytest.approx(0.25, rel=1e-3)


def test_reel_hold_back_follows_the_closed_form_during_the_dead_time():
    # A drum paying out under a hanging weight M (constant torque tau): with the
    # drive's hold-back b (v - v_f) and the speed reference still at rest for the
    # dead time T_d, (I/R^2 + M) v' = M g - tau/R - b v, so
    #   v = v_inf (1 - exp(-t/T)), v_inf = (M g - tau/R)/b, T = (I/R^2 + M)/b
    #   L - L0 = v_inf (t - T (1 - exp(-t/T)))   for t < T_d.
    # The hose (0.01 kg/m) and its axial spring ring at M a/(EA/L) ~ 3e-5 m;
    # tolerance 2e-4 m on ~0.05 m of travel.
    from tests.solver.test_reel import hanging
    R, I, M, tau, b, Td = 0.2, 4.0, 50.0, 60.0, 400.0, 0.4
    reel = ReelProperties(mode="drum", drum_radius_empty=R, drum_width=1e9, drum_inertia_empty=I,
                          torque_law="constant_torque", torque=tau)
    m = hanging(reel, M=M, EA=1e7)
    ml = apply_effects(m, {"reel_lag": {"dead_time_s": Td, "lag_s": 0.0, "hold_N_s_m": b}},
                       EffectContext(1.0, 1.0))
    from tests.solver.helpers import straight_state
    s0 = solve_static(hanging(ReelProperties(), M=M, EA=1e7),
                      guess=straight_state(10, 5.0, direction=(0.0, 0.0, -1.0)).pos)
    r = simulate(ml, 0.8, s0, record_dt=0.01)
    Meff = I / R ** 2 + M + 0.01 * 5.0
    v_inf = (Meff - I / R ** 2) * G / b - tau / R / b
    T = Meff / b
    t = r.t[r.t < Td - 0.01]
    L_an = 5.0 + v_inf * (t - T * (1 - np.exp(-t / T)))
    assert_allclose(r.reel_length[: len(t)], L_an, atol=2e-4)
    # after the dead time the reference catches up and the drum speeds on
    free = simulate(m, 0.8, s0, record_dt=0.01)
    assert r.reel_speed[-1] > r.reel_speed[len(t) - 1] + 0.05
    assert r.reel_length[-1] < free.reel_length[-1]


def test_reel_lag_needs_the_drum():
    m = kdc10_model()
    with pytest.raises(EffectError, match="reel_lag: needs the drum"):
        apply_effects(m, {"reel_lag": {}}, context(m))


def test_reel_lag_stays_stable_on_the_stiff_hose():
    # The hold-back b (1 - H) is passive whatever the delay: with the KDC-10 hose on
    # the drum and a tension drop (a 1-cosine head-on gust cuts the drogue's drag)
    # the run stays bounded and the take-up is slower than the ideal drum's (a
    # 15 m/s head-on gust: the drag falls by a fifth).
    reel = ReelProperties(mode="drum", drum_radius_empty=0.18, drum_width=0.6, drum_inertia_empty=4.0)
    m = kdc10_model(n=16, reel=reel)
    m = apply_effects(m, {"gust": {"longitudinal_mps": -15.0, "vertical_mps": 0.0, "length_m": 60.0,
                                   "start_s": 0.2, "full_wave": 1}}, context(m))
    ml = apply_effects(m, {"reel_lag": {}}, context(m))
    s0 = solve_static(m)
    ideal = simulate(m, 3.0, s0, record_dt=0.01)
    lag = simulate(ml, 3.0, s0, record_dt=0.01)
    assert np.all(np.isfinite(lag.reel_length))
    k = np.searchsorted(lag.t, 0.7)
    assert ideal.reel_length[k] < lag.reel_length[k] - 0.005 < s0.reel_length

