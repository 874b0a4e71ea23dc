"""Parameter types the verbs share: numbers that say what they can mean."""
from __future__ import annotations

import math

import click

class FiniteFloatRange(click.FloatRange):
    """`click.FloatRange` that also refuses NaN and infinity, which pass a
    plain range check (every comparison with NaN is false)."""

    name = "finite float range"

    def convert(self, value, param, ctx):
        rv = super().convert(value, param, ctx)
        if not math.isfinite(rv):
            self.fail(f"{value!r} is not a finite number.", param, ctx)
        return rv


WORKERS = click.IntRange(1, 256)   # processes: one per core of the largest machine we expect
