"""The hardware data sheets (`hardware.toml`): what is known of each hose, drogue,
reel and tanker before flight. Read here, at the edge, into SI values."""
from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

from solver.units import FT
from workbench.errors import InputError
from workbench.provenance import FileCache

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


def _num(path, section, key, raw, required=True, positive=True):
    if key not in raw:
        if required:
            raise InputError(f"{path}: [{section}] is missing '{key}'")
        return None
    v = raw[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise InputError(f"{path}: [{section}] {key} must be a number, got {v!r}")
    if positive and not v > 0:
        raise InputError(f"{path}: [{section}] {key} must be positive, got {v!r}")
    return float(v)


_sheets = FileCache()


def load_hardware(path: str | Path | None = None) -> Hardware:
    """The data sheets of `path` (default: the committed hardware.toml). Read once
    per version of the file: case building calls this inside fit loops."""
    return _sheets.get(path if path is not None else DEFAULT_PATH, _read_hardware)


def _read_hardware(p: Path) -> Hardware:
    try:
        raw = tomllib.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{p}: hardware data sheet file not found") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{p}: not valid TOML ({exc})") from None
    hoses, drogues, reels, tankers = {}, {}, {}, {}
    for hid, h in raw.get("hose", {}).items():
        s = f"hose.{hid}"
        bench = _num(p, s, "bench_section_length_m", h, required=False)
        hoses[hid] = HoseSheet(hid, _num(p, s, "length_ft", h) * FT, _num(p, s, "outer_diameter_m", h),
                               _num(p, s, "inner_diameter_m", h, positive=False),
                               _num(p, s, "dry_mass_per_m", h), bench, h.get("description", ""))
    for did, d in raw.get("drogue", {}).items():
        s = f"drogue.{did}"
        drogues[did] = DrogueSheet(did, _num(p, s, "mass_kg", d), _num(p, s, "diameter_m", d),
                                   _num(p, s, "cd_wind_tunnel", d),
                                   _num(p, s, "cl_wind_tunnel", d, positive=False),
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
                                   _num(p, s, "tow_point_span_station_m", t, positive=False),
                                   t.get("description", ""))
    fuel = _num(p, "fuel", "density_kg_m3", raw.get("fuel", {}), required=False) or 810.0
    return Hardware(str(p), hoses, drogues, reels, tankers, fuel)
