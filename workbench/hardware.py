"""The hardware data sheets (`hardware.toml`): what is known of each hose, drogue,
reel and tanker before flight. Read here, at the edge, into SI values."""
from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

from solver.units import FT
from workbench.errors import InputError
from workbench.provenance import FileCache, read_text_limited

DEFAULT_PATH = Path(__file__).resolve().parent.parent / "flighttest" / "logs" / "hardware.toml"


@dataclass(frozen=True)
class HoseSheet:
    id: str
    length: float               # m
    outer_diameter: float
    inner_diameter: float
    dry_mass_per_length: float  # kg/m
    bench_section_length: float | None
    description: str = ""


@dataclass(frozen=True)
class DrogueSheet:
    id: str
    mass: float
    diameter: float
    cd_wind_tunnel: float
    cl_wind_tunnel: float
    cp_aft_of_hinge: float
    free_play_deg: float
    description: str = ""


@dataclass(frozen=True)
class ReelSheet:
    id: str
    drum_radius_empty: float
    drum_width: float
    drum_inertia_empty: float
    mode: str


@dataclass(frozen=True)
class TankerSheet:
    id: str
    wing_span: float
    tow_point_aft_of_cg: float
    tow_point_below_wing_root: float
    tow_point_span_station: float
    description: str = ""


@dataclass(frozen=True)
class Hardware:
    path: str
    hoses: dict
    drogues: dict
    reels: dict
    tankers: dict
    fuel_density: float

    def get(self, kind: str, ident: str):
        table = {"hose": self.hoses, "drogue": self.drogues, "reel": self.reels, "tanker": self.tankers}[kind]
        if ident not in table:
            known = ", ".join(sorted(table)) or "none"
            raise InputError(f"{self.path}: no {kind} '{ident}' (known: {known})")
        return table[ident]


# Physical ranges of the data-sheet values (SI unless the key says otherwise):
# wide enough for any hose-and-drogue hardware flown, narrow enough that a unit
# slip (mm for m, lb for kg) or a sign is refused.
RANGES = {
    "length_ft": (10.0, 300.0, "a trailed hose (flighttest.schema's hose_length_ft)"),
    "outer_diameter_m": (0.01, 0.3, "a refuelling hose"),
    "inner_diameter_m": (0.0, 0.3, "a refuelling hose's bore"),
    "dry_mass_per_m": (0.1, 50.0, "a refuelling hose, kg/m"),
    "bench_section_length_m": (0.1, 10.0, "a bench-rig section (flighttest.schema's section_length_m)"),
    "mass_kg": (1.0, 500.0, "a drogue"),
    "diameter_m": (0.1, 3.0, "a drogue canopy"),
    "cd_wind_tunnel": (0.05, 3.0, "a bluff body's drag coefficient"),
    "cl_wind_tunnel": (-2.0, 2.0, "a drogue's lift coefficient"),
    "center_of_pressure_aft_of_hinge_m": (0.0, 3.0, "behind the hinge, within a drogue's length"),
    "hinge_free_play_deg": (0.0, 90.0, "a hinge's free swing"),
    "drum_radius_empty_m": (0.01, 2.0, "a reel drum"),
    "drum_width_m": (0.01, 5.0, "a reel drum"),
    "drum_inertia_empty_kg_m2": (0.01, 1e3, "a reel drum"),
    "wing_span_m": (1.0, 100.0, "an aircraft"),
    "tow_point_aft_of_cg_m": (-50.0, 50.0, "within the aircraft's length"),
    "tow_point_below_wing_root_m": (-20.0, 20.0, "within the aircraft's height"),
    "tow_point_span_station_m": (-50.0, 50.0, "within the half span"),
    "density_kg_m3": (500.0, 1100.0, "jet fuels: 775-840 kg/m^3 at 15 C"),
}
# lower bounds that are themselves excluded (a length, mass or diameter of 0)
_OPEN_LO = {"inner_diameter_m": False, "cl_wind_tunnel": False, "tow_point_aft_of_cg_m": False,
            "tow_point_below_wing_root_m": False, "tow_point_span_station_m": False,
            "center_of_pressure_aft_of_hinge_m": True, "hinge_free_play_deg": False}
MAX_FILE_BYTES = 1_000_000   # a data sheet or case is a few kB of text: refuse anything else unread


def read_toml(p: Path, what: str) -> dict:
    """The TOML file `p` (a `what`, named in messages), its size checked before
    it is read."""
    text = read_text_limited(p, what, MAX_FILE_BYTES)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{p}: not valid TOML ({' '.join(str(exc).split())})") from None


def _num(path, section, key, raw, required=True):
    if key not in raw:
        if required:
            raise InputError(f"{path}: [{section}] is missing '{key}'")
        return None
    v = raw[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise InputError(f"{path}: [{section}] {key} must be a number, got {v!r}")
    lo, hi, why = RANGES[key]
    lo_open = _OPEN_LO.get(key, True)
    if not ((v > lo if lo_open else v >= lo) and v <= hi):
        raise InputError(f"{path}: [{section}] {key} must lie in {'(' if lo_open else '['}{lo:g}, {hi:g}] "
                         f"({why}), got {v!r}")
    return float(v)


# every key a data sheet may hold, by section; the text ones are TEXT
KEYS = {
    "hose": ("length_ft", "outer_diameter_m", "inner_diameter_m", "dry_mass_per_m", "bench_section_length_m",
             "description"),
    "drogue": ("mass_kg", "diameter_m", "cd_wind_tunnel", "cl_wind_tunnel", "center_of_pressure_aft_of_hinge_m",
               "hinge_free_play_deg", "description"),
    "reel": ("drum_radius_empty_m", "drum_width_m", "drum_inertia_empty_kg_m2", "mode"),
    "tanker": ("wing_span_m", "tow_point_aft_of_cg_m", "tow_point_below_wing_root_m", "tow_point_span_station_m",
               "description"),
    "fuel": ("density_kg_m3",),
}
TEXT = ("description", "mode")


def _check_keys(p: Path, raw: dict) -> None:
    """Unknown sections and keys (a typo would otherwise leave an optional value unset)."""
    for section, value in raw.items():
        if section not in KEYS:
            raise InputError(f"{p}: unknown table [{section}] (known: {', '.join(KEYS)})")
        if not isinstance(value, dict):
            raise InputError(f"{p}: [{section}] must be a table of [{section}.ID] tables")
        sheets = {section: value} if section == "fuel" else {f"{section}.{i}": v for i, v in value.items()}
        for name, sheet in sheets.items():
            if not isinstance(sheet, dict):
                raise InputError(f"{p}: [{name}] must be a table, got {sheet!r}")
            for key, v in sheet.items():
                if key not in KEYS[section]:
                    raise InputError(f"{p}: [{name}] unknown key '{key}' (known: {', '.join(KEYS[section])})")
                if key in TEXT and not isinstance(v, str):
                    raise InputError(f"{p}: [{name}] {key} must be a string, got {v!r}")


_sheets = FileCache()


def load_hardware(path: str | Path | None = None) -> Hardware:
    """The data sheets of `path` (default: the committed hardware.toml). Read once
    per version of the file: case building calls this inside fit loops."""
    return _sheets.get(path if path is not None else DEFAULT_PATH, _read_hardware)


def _read_hardware(p: Path) -> Hardware:
    raw = read_toml(p, "hardware data sheet file")
    _check_keys(p, raw)
    hoses, drogues, reels, tankers = {}, {}, {}, {}
    for hid, h in raw.get("hose", {}).items():
        s = f"hose.{hid}"
        bench = _num(p, s, "bench_section_length_m", h, required=False)
        hoses[hid] = HoseSheet(hid, _num(p, s, "length_ft", h) * FT, _num(p, s, "outer_diameter_m", h),
                               _num(p, s, "inner_diameter_m", h),
                               _num(p, s, "dry_mass_per_m", h), bench, h.get("description", ""))
        if hoses[hid].inner_diameter >= hoses[hid].outer_diameter:
            raise InputError(f"{p}: [{s}] inner_diameter_m {hoses[hid].inner_diameter:g} must be less than "
                             f"outer_diameter_m {hoses[hid].outer_diameter:g}")
    for did, d in raw.get("drogue", {}).items():
        s = f"drogue.{did}"
        drogues[did] = DrogueSheet(did, _num(p, s, "mass_kg", d), _num(p, s, "diameter_m", d),
                                   _num(p, s, "cd_wind_tunnel", d),
                                   _num(p, s, "cl_wind_tunnel", d),
                                   _num(p, s, "center_of_pressure_aft_of_hinge_m", d),
                                   _num(p, s, "hinge_free_play_deg", d), d.get("description", ""))
    for rid, r in raw.get("reel", {}).items():
        s = f"reel.{rid}"
        reels[rid] = ReelSheet(rid, _num(p, s, "drum_radius_empty_m", r), _num(p, s, "drum_width_m", r),
                               _num(p, s, "drum_inertia_empty_kg_m2", r), str(r.get("mode", "")))
    for tid, t in raw.get("tanker", {}).items():
        s = f"tanker.{tid}"
        tankers[tid] = TankerSheet(tid, _num(p, s, "wing_span_m", t), _num(p, s, "tow_point_aft_of_cg_m", t),
                                   _num(p, s, "tow_point_below_wing_root_m", t),
                                   _num(p, s, "tow_point_span_station_m", t),
                                   t.get("description", ""))
    fuel = _num(p, "fuel", "density_kg_m3", raw.get("fuel", {}), required=False) or 810.0
    return Hardware(str(p), hoses, drogues, reels, tankers, fuel)
