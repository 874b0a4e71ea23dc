"""Option types that check a value's physical range when the command line is
read (click's own FloatRange lets NaN through: every comparison with it is
false)."""
from __future__ import annotations

import math

import click


class FiniteRange(click.ParamType):
    """A finite float in lo..hi (lo excluded when `lo_open`), with the unit in the message."""

    name = "number"

    def __init__(self, lo: float, hi: float, unit: str = "", lo_open: bool = False):
        self.lo, self.hi, self.unit, self.lo_open = lo, hi, unit, lo_open

    def convert(self, value, param, ctx):
        try:
            v = float(value)
        except (TypeError, ValueError):
            self.fail(f"{value!r} is not a number", param, ctx)
        ok = math.isfinite(v) and (v > self.lo if self.lo_open else v >= self.lo) and v <= self.hi
        if not ok:
            unit = f" {self.unit}" if self.unit else ""
            self.fail(f"{value!r} is outside {'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}]{unit}",
                      param, ctx)
        return v


WORKERS = click.IntRange(1, 256)   # processes: one per core of the largest machine we expect
