"""Per-element hose constants from bench-test property tables (paper III.B, Fig. 7).

A `PropertyTable` holds, for one hose, the axial and bending constants of a
hose element (k_a N/m, c_a N s/m, k_b N m/rad, c_b N m s/rad; the meaning of
each is in `solver/hose.py`) tuned at a few temperatures and element lengths.
Looking up a value at (temperature, element length):

- temperature: a cubic spline through the tuned temperatures (not-a-knot end
  conditions), separately for each tuned element length. The tuned
  temperatures are the measured bench temperatures; outside their range the
  spline is an extrapolation, refused unless the caller asks for it.
- element length: log-log linear between tuned lengths, since each constant
  goes as about 1/l (k_b = EI/l in the continuum limit) and its residual
  dependence on l (discretisation) is smooth in log l. Beyond the tuned
  lengths the product constant x length is held at the nearest tuned length,
  which is the continuum scaling the solver itself uses for the reel-exit
  element.

Everything is pure: tables are built from arrays or a dict (the workbench
reads the data file); nothing here reads files.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Mapping

import numpy as np
from scipy.interpolate import CubicSpline

NAMES = ("k_a", "c_a", "k_b", "c_b")
# keys of `to_dict`/`from_dict`, with the unit of each constant in its name
DICT_KEYS = {"k_a": "k_a_N_per_m", "c_a": "c_a_N_s_per_m",
             "k_b": "k_b_N_m_per_rad", "c_b": "c_b_N_m_s_per_rad"}


def _fmt_range(lo: float, hi: float) -> str:
    return f"{lo:.1f}..{hi:.1f} F"


@dataclass(frozen=True, eq=False)
class PropertyTable:
    """Constants of one hose on a (temperature x element length) grid.

    `k_a`, `c_a`, `k_b`, `c_b` have shape (len(temperatures_F),
    len(element_lengths)); temperatures in deg F (the bench unit), element
    lengths in m."""

    hose: str
    temperatures_F: np.ndarray
    element_lengths: np.ndarray
    k_a: np.ndarray
    c_a: np.ndarray
    k_b: np.ndarray
    c_b: np.ndarray
    note: str = ""
    _spline: CubicSpline = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        T = np.asarray(self.temperatures_F, dtype=float)
        L = np.asarray(self.element_lengths, dtype=float)
        if T.ndim != 1 or len(T) < 2 or not np.all(np.isfinite(T)) or np.any(np.diff(T) <= 0):
            raise ValueError(f"hose {self.hose}: temperatures_F must be >= 2 finite increasing values")
        if L.ndim != 1 or len(L) < 1 or not np.all(L > 0) or not np.all(np.isfinite(L)) \
                or np.any(np.diff(L) <= 0):
            raise ValueError(f"hose {self.hose}: element_lengths must be positive increasing values")
        object.__setattr__(self, "temperatures_F", T)
        object.__setattr__(self, "element_lengths", L)
        vals = []
        for name in NAMES:
            a = np.asarray(getattr(self, name), dtype=float)
            if a.shape != (len(T), len(L)):
                raise ValueError(f"hose {self.hose}: {name} has shape {a.shape}, "
                                 f"expected {(len(T), len(L))}")
            if not (np.all(np.isfinite(a)) and np.all(a > 0)):
                raise ValueError(f"hose {self.hose}: {name} must be positive and finite")
            object.__setattr__(self, name, a)
            vals.append(a)
        # one spline over all four constants and every element length (axis 0 is temperature)
        object.__setattr__(self, "_spline", CubicSpline(T, np.stack(vals, axis=1), axis=0,
                                                        bc_type="not-a-knot", extrapolate=True))

    # ---- look-ups -------------------------------------------------------------------
    @property
    def temperature_range_F(self) -> tuple[float, float]:
        return float(self.temperatures_F[0]), float(self.temperatures_F[-1])

    def _columns(self, temperature_F: float, allow_extrapolation: bool) -> np.ndarray:
        """(4, n_lengths) constants at one temperature."""
        T = float(temperature_F)
        lo, hi = self.temperature_range_F
        if not math.isfinite(T):
            raise ValueError(f"hose {self.hose}: temperature {temperature_F!r} F is not finite")
        if not (lo <= T <= hi) and not allow_extrapolation:
            raise ValueError(
                f"hose {self.hose}: temperature {T:.1f} F is outside the tested range "
                f"{_fmt_range(lo, hi)}; pass allow_extrapolation=True to extrapolate the spline")
        cols = self._spline(T)
        if not np.all(cols > 0):
            bad = NAMES[int(np.argmin(np.min(cols, axis=1)))]
            raise ValueError(f"hose {self.hose}: the spline extrapolated to {T:.1f} F gives a "
                             f"non-positive {bad} (tested range {_fmt_range(lo, hi)})")
        return cols

    def _at_length(self, cols: np.ndarray, element_length: float) -> tuple[float, float, float, float]:
        l = float(element_length)
        if not (l > 0 and math.isfinite(l)):
            raise ValueError(f"element length must be positive, got {element_length!r}")
        L = self.element_lengths
        if l <= L[0] or len(L) == 1:
            out = cols[:, 0] * (L[0] / l)
        elif l >= L[-1]:
            out = cols[:, -1] * (L[-1] / l)
        else:
            i = int(np.searchsorted(L, l)) - 1
            w = (math.log(l) - math.log(L[i])) / (math.log(L[i + 1]) - math.log(L[i]))
            out = np.exp((1.0 - w) * np.log(cols[:, i]) + w * np.log(cols[:, i + 1]))
        return tuple(float(x) for x in out)

    def constants(self, temperature_F: float, element_length: float,
                  allow_extrapolation: bool = False) -> tuple[float, float, float, float]:
        """(k_a N/m, c_a N s/m, k_b N m/rad, c_b N m s/rad) of an element of
        `element_length` m at `temperature_F`. A temperature outside the tested
        range raises ValueError unless `allow_extrapolation`."""
        return self._at_length(self._columns(temperature_F, allow_extrapolation), element_length)

    def element_constants(self, temperature_F: float,
                          allow_extrapolation: bool = False) -> Callable[[float], tuple]:
        """The `HoseProperties.element_constants` callable for one temperature
        (the temperature is checked here, once)."""
        cols = self._columns(temperature_F, allow_extrapolation)
        return lambda element_length: self._at_length(cols, element_length)

    def continuum(self, temperature_F: float, allow_extrapolation: bool = False) -> dict:
        """Continuum-equivalent EA (N), eta_a (N s), EI (N m^2), eta_b (N m^2 s):
        constant x length of the shortest tuned element, the best-resolved one."""
        cols = self._columns(temperature_F, allow_extrapolation)
        l = float(self.element_lengths[0])
        ka, ca, kb, cb = cols[:, 0] * l
        return {"EA": float(ka), "axial_damping": float(ca), "EI": float(kb),
                "bending_damping": float(cb)}

    # ---- derived tables and (de)serialisation -------------------------------------
    def scaled(self, hose: str, factor: float, note: str = "") -> "PropertyTable":
        """The same table with every constant multiplied by `factor` (a hose of
        like construction, another cross-section), named `hose`."""
        if not (factor > 0 and math.isfinite(factor)):
            raise ValueError(f"scale factor must be positive, got {factor!r}")
        return PropertyTable(hose, self.temperatures_F, self.element_lengths,
                             self.k_a * factor, self.c_a * factor, self.k_b * factor,
                             self.c_b * factor, note=note)

    def to_dict(self) -> dict:
        d = {"hose": self.hose, "temperatures_F": self.temperatures_F.tolist(),
             "element_lengths_m": self.element_lengths.tolist()}
        for name in NAMES:
            d[DICT_KEYS[name]] = getattr(self, name).tolist()
        if self.note:
            d["note"] = self.note
        return d

    @classmethod
    def from_dict(cls, d: Mapping) -> "PropertyTable":
        try:
            return cls(str(d["hose"]), np.asarray(d["temperatures_F"], dtype=float),
                       np.asarray(d["element_lengths_m"], dtype=float),
                       *(np.asarray(d[DICT_KEYS[n]], dtype=float) for n in NAMES),
                       note=str(d.get("note", "")))
        except KeyError as exc:
            raise ValueError(f"property table {d.get('hose', '?')!r} lacks {exc.args[0]!r}") from None


class PropertyLibrary:
    """Property tables by hose id."""

    def __init__(self, tables: Mapping[str, PropertyTable] | list[PropertyTable]):
        items = tables.values() if isinstance(tables, Mapping) else tables
        self._tables = {t.hose: t for t in items}

    @property
    def hoses(self) -> tuple[str, ...]:
        return tuple(sorted(self._tables))

    def table(self, hose: str) -> PropertyTable:
        if hose not in self._tables:
            raise ValueError(f"no property table for hose {hose!r} "
                             f"(tables: {', '.join(self.hoses) or 'none'})")
        return self._tables[hose]

    def constants(self, hose: str, temperature_F: float, element_length: float,
                  allow_extrapolation: bool = False) -> tuple[float, float, float, float]:
        return self.table(hose).constants(temperature_F, element_length, allow_extrapolation)

    def element_constants(self, hose: str, temperature_F: float,
                          allow_extrapolation: bool = False) -> Callable[[float], tuple]:
        return self.table(hose).element_constants(temperature_F, allow_extrapolation)

    @classmethod
    def from_dict(cls, tables: Mapping[str, Mapping]) -> "PropertyLibrary":
        """From {hose id: PropertyTable.to_dict()}."""
        out = []
        for hose, d in tables.items():
            t = PropertyTable.from_dict(d)
            if t.hose != hose:
                raise ValueError(f"property table under {hose!r} is for hose {t.hose!r}")
            out.append(t)
        return cls(out)
