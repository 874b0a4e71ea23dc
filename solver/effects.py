"""The unmodelled-effect library: every candidate explanation of a flight-test
mismatch as a switchable, documented model component.

The paper's model (ARES) leaves out the tanker wake, turbulence, the receiver's
bow wave, steady wind and gusts; its flight comparisons found the drogue flying
with far less lift than the wind tunnel measured, and engagements 8 and 9
trailing differently from 7 and 11 at the same speed and altitude. Each entry
of `EFFECTS` is one candidate: off unless named (the paper's baseline), a few
parameters with units, physical ranges and defaults, the model and its source.

`apply_effects(model, {name: {param: value}}, context)` returns a new `Model`
with the effects composed; the wind-type effects add components to the
model's `WindField` (`solver.wind`), the others change drogue, hose or reel
properties. `sensor_lag` acts on the comparison with flight data, not on the
physics: it is listed here (flagged `comparison_only`) so cases validate it
like any other, and `workbench.effects_compare` applies it.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Callable, Mapping, Optional

import numpy as np

from solver import wind as W
from solver.model import Model, Trajectory

G0 = 9.80665


class EffectError(ValueError):
    """A bad effect request; `effect` and `key` name what is wrong."""

    def __init__(self, effect: str, key: Optional[str], problem: str):
        self.effect = effect
        self.key = key
        self.problem = problem
        where = f"{effect}.{key}" if key else effect
        super().__init__(f"effect {where}: {problem}")


@dataclass(frozen=True)
class Param:
    """One effect parameter: unit, default (its value when the effect is on and
    the parameter not given), physical range lo..hi and doc; and the
    calibration metadata, written here only:

    * `off`: the value at which the parameter adds nothing to the baseline (a
      factor's 1, a strength's or a wind's 0); for one that only shapes an
      effect switched on by another parameter (a core radius, a seed), its
      default. The diagnosis measures every change from it.
    * `search`: the range the diagnosis calibrates the parameter over (inside
      lo..hi); None: the diagnosis holds it at its default.
    * `probe`: the value the diagnosis's sensitivity screen probes (and its
      mirror about `off` in the search's scale).
    * `log`: the search's grid is logarithmic (a factor spanning decades).
    * `refined`: a form parameter of the effect, searched only once the
      effect is selected (`Effect.refined`), not when it competes to enter.
    * `tolerance`: for a factor on a known value (a wind-tunnel coefficient, a
      handbook coefficient, a bench stiffness), that value's own plausible
      spread as a fraction: a factor fitted within off x (1 +/- tolerance)
      is a calibration of the value the data sheet already gives, not an
      unmodelled effect. None: the parameter is no such factor.
    """

    unit: str
    default: float
    lo: float
    hi: float
    doc: str
    integer: bool = False
    off: Optional[float] = None
    search: Optional[tuple] = None
    probe: Optional[float] = None
    log: bool = False
    tolerance: Optional[float] = None
    scan_s: Optional[float] = None
    refined: bool = False

    def check(self, value) -> Optional[str]:
        """A complaint about `value`, or None."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return f"must be a number, got {value!r}"
        if not math.isfinite(value):
            return f"must be finite, got {value!r}"
        if self.integer and float(value) != int(value):
            return f"must be an integer, got {value!r}"
        if not (self.lo <= value <= self.hi):
            unit = f" {self.unit}" if self.unit not in ("-", "") else ""
            return f"must lie in {self.lo:g}..{self.hi:g}{unit}, got {value!r}"
        return None


@dataclass(frozen=True)
class TankerGeometry:
    """What the tanker data sheet says about the wing and the tow point (m)."""

    wing_span: float
    tow_point_aft_of_cg: float
    tow_point_below_wing_root: float
    tow_point_span_station: float     # + starboard of the centre line


@dataclass(frozen=True)
class EffectContext:
    """What effects need to know beyond the model: the flight condition, the
    tanker, how long the run lasts (tables cover it) and the receiver's probe."""

    true_airspeed: float              # m/s
    air_density: float               # kg/m^3
    altitude_m: float = 0.0
    t_start: float = 0.0             # s
    duration_s: float = 60.0         # s of simulated time the tables must cover
    tanker: Optional[TankerGeometry] = None
    gross_weight_kg: Optional[float] = None
    probe_path: Optional[Trajectory] = None   # probe tip, tow-point frame


@dataclass(frozen=True)
class Effect:
    name: str
    title: str
    model: str            # the physical model, in words
    source: str           # where the model comes from
    params: dict
    apply: Optional[Callable] = field(default=None, repr=False)
    comparison_only: bool = False
    not_calibrated: Optional[str] = None   # why no parameter has a search range
    # a difference of definition between the model and the instruments in every log of the
    # hardware (not an event of one flight): the diagnosis fits it and reports it as model form
    model_form: bool = False

    @property
    def calibrated(self) -> list[str]:
        """The parameters the diagnosis calibrates, in the registry's order."""
        return [k for k, p in self.params.items() if p.search is not None and not p.refined]

    @property
    def refined(self) -> list[str]:
        """Its form parameters (`Param.refined`): searched on a selected set only."""
        return [k for k, p in self.params.items() if p.search is not None and p.refined]

    @property
    def scanned(self) -> list[str]:
        """Its calibrated times in one log (`Param.scan_s`, a transient's): no
        other log shares them, so it is fitted on one log at a time."""
        return [k for k in self.calibrated if self.params[k].scan_s]


# ---- helpers ---------------------------------------------------------------------------

def _reach(model: Model) -> float:
    """Farthest a hose point can get from the tow point, m (all hose paid out)."""
    link = model.drogue.link_length if model.drogue is not None else 0.0
    return model.hose.stowed_length + link + 2.0


def _need(ctx: EffectContext, name: str, what: str):
    v = getattr(ctx, what)
    if v is None:
        raise EffectError(name, None, f"needs {what.replace('_', ' ')} in the context")
    return v


# ---- model-property effects ------------------------------------------------------------

def _drogue(model, name):
    if model.drogue is None:
        raise EffectError(name, None, "the model has no drogue")
    return model.drogue


def _apply_drogue_lift(model, p, ctx):
    d = _drogue(model, "drogue_lift")
    return dataclasses.replace(model, drogue=dataclasses.replace(d, lift_scale=d.lift_scale * p["scale"]))


def _apply_drogue_drag(model, p, ctx):
    d = _drogue(model, "drogue_drag")
    return dataclasses.replace(model, drogue=dataclasses.replace(d, drag_scale=d.drag_scale * p["scale"]))


def _apply_hose_drag(model, p, ctx):
    # the kernel's P_HOSE_DRAG scales crossflow and skin friction together; the
    # friction coefficient takes the ratio so each gets its own factor
    cf, fr = p["crossflow"], p["friction"]
    s = model.hose_drag_scale * cf
    hose = dataclasses.replace(model.hose, ca0=model.hose.ca0 * fr / cf)
    return dataclasses.replace(model, hose=hose, hose_drag_scale=s)


def _apply_hose_stiffness(model, p, ctx):
    sb, sa = p["bending"], p["axial"]
    h = model.hose
    if h.element_constants is not None:
        hose = dataclasses.replace(h, element_constants=_ScaledConstants(h.element_constants, sa, sb))
    else:
        hose = dataclasses.replace(h, EI=h.EI * sb, EA=h.EA * sa)
    return dataclasses.replace(model, hose=hose)


@dataclass(frozen=True)
class _ScaledConstants:
    """A property table's (k_a, c_a, k_b, c_b) with the stiffnesses scaled (a
    class, not a closure, so models stay picklable for worker processes)."""

    base: Callable
    axial: float
    bending: float

    def __call__(self, l):
        ka, ca, kb, cb = self.base(l)
        return (ka * self.axial, ca, kb * self.bending, cb)


def _apply_reel_lag(model, p, ctx):
    if model.reel.mode != "drum":
        raise EffectError("reel_lag", None, "needs the drum reel mode ([model] reel = 'drum')")
    reel = dataclasses.replace(model.reel, drive_dead_time=p["dead_time_s"], drive_lag=p["lag_s"],
                               drive_hold=p["hold_N_s_m"])
    return dataclasses.replace(model, reel=reel)


# ---- wind effects ----------------------------------------------------------------------

def _apply_steady_wind(model, p, ctx):
    return dataclasses.replace(model, wind=model.wind.plus(W.UNIFORM, [0.0, p["lateral_mps"], p["vertical_mps"]]))


def tanker_wake_params(model: Model, p: Mapping, ctx: EffectContext, grid: bool = True) -> np.ndarray:
    """The VORTEX_WAKE parameters of `tanker_wake` for this model and context."""
    tk = _need(ctx, "tanker_wake", "tanker")
    mass = _need(ctx, "tanker_wake", "gross_weight_kg")
    lift = p["strength"] * mass * G0
    y_c = -tk.tow_point_span_station + p["lateral_offset_m"]
    z_w = tk.tow_point_below_wing_root + p["vertical_offset_m"]
    x_b = -tk.tow_point_aft_of_cg
    fin, semi, _ = W.elliptic_lifting_line(lift, ctx.air_density, ctx.true_airspeed, tk.wing_span,
                                           x_b, y_c, z_w, n_panels=WAKE_PANELS)
    fus = None
    cda = p["strength"] * p["fuselage_drag_area_m2"]
    if cda > 0:
        r_f = math.sqrt(cda / FUSELAGE_CD_FRONTAL / math.pi)
        fus = W.FuselageWake(drag_area=cda, x_origin=x_b, y_axis=y_c, z_axis=z_w + r_f,
                             U=ctx.true_airspeed, r0=r_f)
    box = None
    spacing = 0.5
    if grid:
        R = _reach(model)
        # where the hose goes: aft and below the tow point, a slack loop forward;
        # outside the box the filament sums answer (exact, slower)
        box = ((-0.3 * R, R + 1.0), (-0.4 * R, 0.4 * R), (-0.8 * R, 0.25 * R))
        vol = np.prod([hi - lo for lo, hi in box])
        spacing = min(1.0, max(0.25, (vol / WAKE_GRID_NODES) ** (1.0 / 3.0)))
    return W.vortex_wake(fin, semi, p["core_radius_m"], fuselage=fus, box=box, spacing=spacing)


WAKE_PANELS = 80            # cosine-spaced horseshoes: far-wake downwash within 0.1 %
WAKE_GRID_NODES = 150_000   # ~3.6 MB of float64; 0.5 m spacing for the KDC-10's 75 ft hose
FUSELAGE_CD_FRONTAL = 0.1   # fuselage drag coefficient on frontal area (Hoerner 1965, Ch. 6)


def _apply_tanker_wake(model, p, ctx):
    return dataclasses.replace(model, wind=model.wind.plus(W.VORTEX_WAKE, tanker_wake_params(model, p, ctx)))


def _apply_turbulence(model, p, ctx):
    U = ctx.true_airspeed
    R = _reach(model) + 1.0
    t1 = ctx.t_start + ctx.duration_s + 1.0
    L = p["length_scale_m"]
    par = W.dryden_table(p["sigma_mps"], L, 0.5 * L, 0.5 * L, U, -R - U * t1, R - U * ctx.t_start,
                         TURBULENCE_DXI, int(p["seed"]))
    return dataclasses.replace(model, wind=model.wind.plus(W.FROZEN_1D, par))


TURBULENCE_DXI = 0.5   # m: 2 ms of convection at 250 m/s, far below the hose's periods


def _apply_gust(model, p, ctx):
    amp = [p["longitudinal_mps"], p["lateral_mps"], p["vertical_mps"]]
    par = W.one_minus_cosine(ctx.true_airspeed, p["start_s"], p["length_m"], p["full_wave"] != 0, amp)
    return dataclasses.replace(model, wind=model.wind.plus(W.ONE_MINUS_COSINE, par))


def probe_approach(model: Model, p: Mapping, ctx: EffectContext) -> Trajectory:
    """The probe path bow_wave uses: the context's, or a straight approach along
    -x to the drogue's static position at `closure_rate_mps`, starting
    `start_gap_m` behind it, holding station at contact."""
    if ctx.probe_path is not None:
        return ctx.probe_path
    from solver.statics import solve_static
    if model.drogue is None:
        raise EffectError("bow_wave", None, "without a probe path in the context the receiver aims at the "
                          "drogue, and the model has none")
    aim = solve_static(model, ctx.t_start).pos[-1]
    t_contact = ctx.t_start + p["start_gap_m"] / p["closure_rate_mps"]
    t_end = max(ctx.t_start + ctx.duration_s, t_contact) + 1.0
    t = np.array([ctx.t_start, t_contact, t_end])
    xyz = np.vstack([aim + [p["start_gap_m"], 0.0, 0.0], aim, aim])
    return Trajectory(t, xyz)


def bow_wave_params(model: Model, p: Mapping, ctx: EffectContext) -> np.ndarray:
    path = probe_approach(model, p, ctx)
    U = ctx.true_airspeed
    R = p["body_radius_m"]
    Q = p["strength"] * math.pi * R * R * U
    a = math.sqrt(Q / (4 * math.pi * U)) if Q > 0 else 0.5 * R
    t1 = max(ctx.t_start + ctx.duration_s, float(path.t[-1])) + 1.0
    ts = np.arange(ctx.t_start, t1 + BOW_DT, BOW_DT)
    probe = path.at(ts)
    nose = probe + np.array([p["nose_x_m"], p["nose_y_m"], p["nose_z_m"]])
    # the source sits a = R/2 behind the nose (the half-body's stagnation point)
    src = nose + np.array([a, 0.0, 0.0])
    return W.moving_source(Q, a, ctx.t_start, BOW_DT, src)


BOW_DT = 0.01   # s: the probe moves < 5 cm a sample at any closure rate flown


def _apply_bow_wave(model, p, ctx):
    return dataclasses.replace(model, wind=model.wind.plus(W.MOVING_SOURCE, bow_wave_params(model, p, ctx)))


# ---- the registry ----------------------------------------------------------------------

EFFECTS: dict[str, Effect] = {}


def _register(e: Effect):
    EFFECTS[e.name] = e


_register(Effect(
    "tanker_wake", "Tanker wing and fuselage wake",
    model=("The wing as Prandtl's lifting line with elliptic loading, root circulation Gamma0 = 4 W / (pi rho V "
           "b) from the gross weight W, span b, true airspeed V and density rho, cut into 80 cosine-spaced "
           "horseshoes whose trailing legs form a flat sheet along the free stream (the near wake: the sheet "
           "rolls up into two tip vortices only several spans behind the wing, Spreiter & Sacks 1951, and the "
           "hose trails within half a span). Each filament has a Hallock-Burnham core. The straight, unswept "
           "bound vortex passes through the tanker's centre of gravity, the sheet lies at the wing root's height"
           " above the tow point, and the centre line sits at minus the tow point's span station (data sheet), "
           "each moved by the offsets. Far behind the wing the sheet's downwash is 2 C_L V / (pi AR) across the "
           "whole span; at the wing, half that. For a centre-line store the fuselage's wake matters too: a self-"
           "similar axisymmetric Gaussian velocity deficit carrying the momentum deficit of the fuselage's drag "
           "area, from the CG station, its axis one fuselage radius above the wing root (low-wing tankers). The "
           "field is steady in the tow-point frame and is sampled on a grid around the hose once per model. The "
           "bound vortex's near field at the tow point is the least certain part: a real wing spreads it over "
           "the chord, and the core radius stands for that. For a wing pod so is the sheet's span position: "
           "rolling up, the sheet gathers towards vortices pi/4 of the semi-span out, which trades sidewash for "
           "downwash at the pod's hose; the lateral offset, refined once the wake is selected, stands for that. "
           "So is the sheet's height (the vertical offset, 3 m either way): the sheet descends at the downwash "
           "angle, ~0.05 rad, over the 20-30 m to a pod's drogue, and moves with the tanker's attitude."),
    source=("Anderson, Fundamentals of Aerodynamics, 5th ed., Sec. 5.3 (lifting line, elliptic loading); Katz & "
            "Plotkin, Low-Speed Aerodynamics, 2nd ed., Eq. 2.68 (Biot-Savart segment); Hallock & Burnham (1982) "
            "vortex core; Spreiter & Sacks (1951) roll-up distance; Pope, Turbulent Flows (2000), Sec. 5.2 "
            "(axisymmetric wake, spreading rate 0.51); Hoerner, Fluid-Dynamic Drag (1965), Ch. 6 (fuselage drag)."),
    params={
        "strength": Param("-", 1.0, 0.0, 3.0, "scale on the circulation and the fuselage deficit",
                          off=0.0, search=(0.0, 3.0), probe=0.5),
        "vertical_offset_m": Param("m", 0.0, -5.0, 5.0, "raises the sheet (dihedral, wake descent: negative)",
                                   off=0.0, search=(-3.0, 3.0), probe=1.0, refined=True),
        "lateral_offset_m": Param("m", 0.0, -10.0, 10.0, "moves the whole wake to starboard", off=0.0,
                                  search=(-6.0, 6.0), probe=3.0, refined=True),
        "core_radius_m": Param("m", 1.0, 0.05, 5.0, "Hallock-Burnham core of every filament", off=1.0),
        "fuselage_drag_area_m2": Param("m^2", 0.6, 0.0, 10.0,
                                       "fuselage C_D A (0.6: a business jet such as the G-III)", off=0.6),
    },
    apply=_apply_tanker_wake))

_register(Effect(
    "drogue_lift", "In-flight drogue lift",
    model="Multiplies the drogue's wind-tunnel lift coefficient (on top of [model] drogue_lift_scale).",
    source="ARES paper, Sec. IV.B: the flight trail shows far less drogue lift than the wind tunnel.",
    # a drogue's C_L is a small difference of pressures that the tunnel's
    # support, blockage and flow-angle corrections move by a quarter of itself
    params={"scale": Param("-", 1.0, 0.0, 3.0, "factor on C_L", off=1.0, search=(0.0, 3.0), probe=0.5,
                           tolerance=0.25)},
    apply=_apply_drogue_lift))

_register(Effect(
    "drogue_drag", "In-flight drogue drag",
    model="Multiplies the drogue's wind-tunnel drag coefficient (on top of [model] drogue_drag_scale).",
    source="ARES paper, Eq. 10: drag coefficient and area matched to the drogue's measured drag.",
    # the drag a drogue is designed and sized by: the tunnel's figure carries
    # its blockage correction and the canopy's shape in flight, a tenth of it
    params={"scale": Param("-", 1.0, 0.2, 3.0, "factor on C_D", off=1.0, search=(0.3, 3.0), probe=1.5,
                            log=True, tolerance=0.10)},
    apply=_apply_drogue_drag))

_register(Effect(
    "turbulence", "Dryden turbulence",
    model=("Medium/high-altitude Dryden turbulence (isotropic: sigma_u = sigma_v = sigma_w, L_u = 2 L_v = 2 "
           "L_w): each component is its MIL-HDBK-1797 forming filter driven by seeded white noise, discretised "
           "exactly in distance, frozen and carried downstream with the air (Taylor's hypothesis), so a gust "
           "reaches the drogue later than the tow point. The field varies along the flight path only: across the "
           "hose (tens of metres) against L_u = 533 m the correlation stays above 0.96. The tanker's own "
           "response to the turbulence is the tow point's prescribed motion, not this effect's."),
    source=("MIL-HDBK-1797 (1997) Sec. 4.9.2 / MIL-F-8785C Sec. 3.7: Dryden spectra and forming filters, scale "
            "length 1750 ft above 2000 ft, intensity from the probability-of-exceedance chart (at 15 000 ft: "
            "light 4.6, moderate 8.0, severe 22.1 ft/s; `mil_hdbk_1797_sigma`)."),
    params={
        "sigma_mps": Param("m/s", 1.4, 0.0, 10.0, "rms of each component (1.4: light at 15 000 ft)", off=0.0),
        "length_scale_m": Param("m", 533.4, 50.0, 2000.0, "longitudinal scale L_u (1750 ft)", off=533.4),
        "seed": Param("-", 1, 0, 2 ** 31 - 1, "random seed: same seed, same field", integer=True, off=1),
    },
    apply=_apply_turbulence,
    not_calibrated=("a random field: its realisation cannot be fitted to a time history; the diagnosis "
                    "estimates sigma from the drogue's random motion above the log's own noise "
                    "(workbench.diagnosis.turbulence)")))

_register(Effect(
    "bow_wave", "Receiver bow wave",
    model=("The receiver's forebody as a Rankine half-body: a point source of volume flux Q = pi R^2 V "
           "(asymptotic body radius R) in the free stream V, placed R/2 behind the nose (the stagnation point), "
           "moving with the probe; the source's field Q r / (4 pi |r|^3) is added to the air velocity. The probe "
           "tip follows the context's probe path, or approaches the drogue's static position along -x at the "
           "closure rate from `start_gap_m` and holds station at contact (no contact model here); a case with a "
           "log flies the logged probe track. The nose sits at the given offsets from the probe tip (an "
           "F/A-18E/F's probe is to starboard of and above the nose)."),
    source=("Anderson, Fundamentals of Aerodynamics, 5th ed., Sec. 6.5 (3D source, Rankine half-body: stagnation "
            "point sqrt(Q / 4 pi V) ahead of the source, radius sqrt(Q / pi V)); Katz & Plotkin, Sec. 3.8."),
    params={
        "strength": Param("-", 1.0, 0.0, 3.0, "scale on the source strength", off=0.0, search=(0.0, 3.0), probe=1.0),
        "body_radius_m": Param("m", 1.0, 0.2, 3.0, "equivalent radius of the receiver's forebody", off=1.0),
        "nose_x_m": Param("m", 1.0, 0.0, 5.0, "nose (stagnation point) aft of the probe tip", off=1.0),
        "nose_y_m": Param("m", -0.9, -3.0, 3.0, "nose to starboard of the probe tip", off=-0.9),
        "nose_z_m": Param("m", -0.5, -3.0, 3.0, "nose above the probe tip", off=-0.5),
        "closure_rate_mps": Param("m/s", 2.0, 0.1, 10.0, "approach speed (3.89 kts in engagement 7)", off=2.0),
        "start_gap_m": Param("m", 10.0, 0.5, 100.0, "probe tip behind the drogue at the start", off=10.0),
    },
    apply=_apply_bow_wave))

_register(Effect(
    "steady_wind", "Steady relative wind at the pod",
    model=("A constant air velocity added in the tow-point frame: a vertical component is a change of the local "
           "flow angle at the pod (angle of attack, upwash), d_alpha ~ -vertical / V; a lateral one a sideslip, "
           "beta ~ lateral / V. It rotates the relative wind the hose and drogue see; gravity stays put, so the "
           "trail turns by less than the wind."),
    source="Kinematics of the relative wind (no model uncertainty); ARES paper, Sec. IV.B.2 future work.",
    params={
        "vertical_mps": Param("m/s", 0.0, -20.0, 20.0, "air moving up through the frame", off=0.0,
                               search=(-6.0, 6.0), probe=1.0),
        "lateral_mps": Param("m/s", 0.0, -20.0, 20.0, "air moving to starboard", off=0.0,
                              search=(-6.0, 6.0), probe=1.0),
    },
    apply=_apply_steady_wind))

_register(Effect(
    "gust", "Discrete 1-cosine gust",
    model=("MIL-HDBK-1797 discrete gust v = V_m/2 (1 - cos(pi x / d_m)) over the ramp length d_m, then V_m held; "
           "or, `full_wave` = 1, back to zero over another d_m (the '1-cosine' pulse). The gust front is frozen "
           "in the air: it passes the tow point at `start_s` and reaches the drogue a hose length / V later."),
    source="MIL-HDBK-1797 (1997) Sec. 4.9.2, discrete gust model (MIL-F-8785C Sec. 3.7.2).",
    params={
        # a vertical gust (MIL-HDBK-1797's for a pitch response), its length held at the default: time
        # and amplitude take most of another length's signature on a drogue whose mode outlasts the gust
        "vertical_mps": Param("m/s", 3.0, -20.0, 20.0, "gust amplitude V_m, up", off=0.0, search=(-6.0, 6.0),
                              probe=2.0),
        "lateral_mps": Param("m/s", 0.0, -20.0, 20.0, "gust amplitude V_m, to starboard", off=0.0),
        "longitudinal_mps": Param("m/s", 0.0, -20.0, 20.0, "gust amplitude V_m, downstream", off=0.0),
        "length_m": Param("m", 100.0, 1.0, 2000.0, "ramp length d_m", off=100.0),
        "start_s": Param("s", 2.0, 0.0, 1e5, "time the front passes the tow point", off=2.0,
                         search=(0.0, 3600.0), probe=10.0, scan_s=1.0),
        "full_wave": Param("-", 1, 0, 1, "1: up and back down (pulse); 0: ramp and hold", integer=True,
                           off=1),
    },
    apply=_apply_gust))

_register(Effect(
    "hose_drag", "Hose drag",
    model="Scales the hose's crossflow drag (Eq. 7 regimes) and its skin friction (Eq. 8) separately.",
    source="ARES paper, Eqs. 3-9 (Jorgensen / Hoerner coefficients, not measured on these hoses).",
    params={
        # a handbook cylinder's C_Dn: roughness and Reynolds number move it by a fifth
        "crossflow": Param("-", 1.0, 0.25, 4.0, "factor on C_Dn", off=1.0, search=(0.25, 4.0), probe=1.6,
                           log=True, tolerance=0.20),
        "friction": Param("-", 1.0, 0.0, 10.0, "factor on the skin-friction coefficient", off=1.0),
    },
    apply=_apply_hose_drag))

_register(Effect(
    "hose_stiffness", "Hose stiffness",
    model="Scales the bending (EI) and axial (EA) stiffness, or the property table's k_b and k_a.",
    source="ARES paper, Sec. III.A: KDC-10 hose properties scaled from the KC-130 hose, never measured.",
    params={
        # a bench ring-down's EI, or one scaled from a like hose: a rubber
        # hose's EI moves with temperature and pressure by nearly a third
        "bending": Param("-", 1.0, 0.1, 10.0, "factor on EI", off=1.0, search=(0.1, 10.0), probe=3.0, log=True,
                         tolerance=0.30),
        "axial": Param("-", 1.0, 0.1, 10.0, "factor on EA", off=1.0),
    },
    apply=_apply_hose_stiffness))

_register(Effect(
    "reel_lag", "Reel drive lag",
    model=("The drum (Eq. 12) with a drive that holds it at the speed it had until its "
           "controller responds: a force b (L' - L'_f) at the rim against the payout speed L', "
           "with L'_f the speed seen through the controller's dead time and first-order lag. "
           "A tension change therefore reaches the take-up late: at low frequencies the "
           "hold-back is an added inertia b (dead time + lag), at high ones a damper b. The "
           "form b (1 - H) is passive for any delay (|H| <= 1); feeding a delayed tension "
           "back into the drum instead destabilises the hose's stiff, lightly damped axial "
           "mode at any useful gain."),
    source=("ARES paper, Sec. V.B: the reel take-up lags the drogue by about 0.2 s in engagement 7; "
            "Eq. 12 drum model; passivity of b (1 - e^(-s T) / (1 + s tau)): Re >= 0 on the "
            "imaginary axis."),
    params={
        "dead_time_s": Param("s", 0.2, 0.0, 1.0, "controller dead time", off=0.0, search=(0.0, 1.0), probe=0.2),
        "lag_s": Param("s", 0.05, 0.0, 2.0, "first-order lag time constant", off=0.05),
        "hold_N_s_m": Param("N s/m", 2000.0, 0.0, 1e5, "how firmly the drive holds the drum's speed", off=0.0),
    },
    apply=_apply_reel_lag))

_register(Effect(
    "sensor_lag", "Optical tracker time shift",
    model=("The optical drogue tracker's samples describe the drogue `delay_s` earlier than "
           "their time stamps say (processing latency); the comparison reads the tracker "
           "channel at t + delay_s. Applied to the comparison with flight data, not to the physics."),
    source="ARES paper, Sec. V.B (channels of different systems); flight-log contract SCHEMA.md.",
    params={"delay_s": Param("s", 0.1, -1.0, 1.0, "tracker latency (negative: tracker early)", off=0.0,
                              search=(-0.8, 0.8), probe=0.15)},
    comparison_only=True))

_register(Effect(
    "drogue_reference", "Tracked point on the drogue",
    model=("The optical tracker follows a point on the drogue `offset_m` aft (negative: forward) of "
           "the model's drogue centre, its centre of mass between the hinge and the data sheet's "
           "centre of pressure: the tracker's target (the canopy rim or the coupling) is not that "
           "point. Along the drogue's axis, taken as the free stream (x): the hinge keeps the axis "
           "within 22.5 deg of the hose end, cos 22.5 deg = 0.92. Applied to the comparison with "
           "flight data (the logged fixes moved by -offset_m in x), not to the physics."),
    source=("Flight-log contract SCHEMA.md (/ors/drogue: 'drogue centre', a point the contract does "
            "not locate on the drogue); hardware.toml (the data sheet's hinge-to-centre-of-pressure "
            "distance); issue 13 (the 0.2 m fore-aft drogue offset common to the KDC-10 logs)."),
    params={"offset_m": Param("m", -0.2, -1.0, 1.0, "tracked point aft of the model's drogue centre", off=0.0,
                              search=(-0.6, 0.6), probe=0.2)},
    comparison_only=True, model_form=True))

# the order effects compose in: properties, winds, then the bow wave (aimed where the others put the drogue)
ORDER = ("drogue_lift", "drogue_drag", "hose_drag", "hose_stiffness", "reel_lag",
         "steady_wind", "tanker_wake", "turbulence", "gust", "bow_wave", "sensor_lag", "drogue_reference")
assert set(ORDER) == set(EFFECTS)


def validate_effects(effects: Mapping[str, Mapping]) -> dict:
    """Check names, parameters and ranges; return {name: {param: value}} with
    the defaults filled in. Raises EffectError naming the effect and key."""
    out = {}
    for name, given in effects.items():
        if name not in EFFECTS:
            raise EffectError(name, None, f"unknown effect (known: {', '.join(ORDER)})")
        e = EFFECTS[name]
        if given is None:
            given = {}
        if not isinstance(given, Mapping):
            raise EffectError(name, None, f"parameters must be a table, got {given!r}")
        vals = {}
        for key, value in given.items():
            if key not in e.params:
                raise EffectError(name, key, f"unknown parameter (known: {', '.join(e.params)})")
            msg = e.params[key].check(value)
            if msg:
                raise EffectError(name, key, msg)
            vals[key] = int(value) if e.params[key].integer else float(value)
        for key, prm in e.params.items():
            vals.setdefault(key, prm.default)
        out[name] = vals
    return out


def apply_effects(model: Model, effects: Mapping[str, Mapping], context: EffectContext) -> Model:
    """`model` with every named effect applied (validated first); comparison-only
    effects leave the model alone."""
    eff = validate_effects(effects)
    for name in ORDER:
        if name in eff and not EFFECTS[name].comparison_only:
            model = EFFECTS[name].apply(model, eff[name], context)
    return model


# MIL-F-8785C Fig. 7 / MIL-HDBK-1797: rms turbulence (ft/s) above 2000 ft against altitude (ft)
_POE_ALT_FT = np.array([500, 1750, 3750, 7500, 15000, 25000, 35000, 45000, 55000, 65000, 75000, 80000.0])
_POE_SIGMA_FTPS = {
    "light": np.array([6.6, 6.9, 7.4, 6.7, 4.6, 2.7, 0.4, 0, 0, 0, 0, 0]),              # 1e-2
    "moderate": np.array([8.6, 9.6, 10.6, 10.1, 8.0, 6.6, 5.0, 4.2, 2.7, 0, 0, 0]),     # 1e-3
    "severe": np.array([15.6, 17.6, 23.0, 23.6, 22.1, 20.0, 16.0, 15.1, 12.1, 7.9, 6.2, 5.1]),  # 1e-5
}


def mil_hdbk_1797_sigma(altitude_m: float, level: str = "light") -> float:
    """Medium/high-altitude Dryden rms intensity (m/s) at an altitude for 'light',
    'moderate' or 'severe' turbulence (probability of exceedance 1e-2, 1e-3, 1e-5)."""
    if level not in _POE_SIGMA_FTPS:
        raise ValueError(f"turbulence level {level!r} is not one of {', '.join(_POE_SIGMA_FTPS)}")
    ft = altitude_m / 0.3048
    return float(np.interp(ft, _POE_ALT_FT, _POE_SIGMA_FTPS[level])) * 0.3048
