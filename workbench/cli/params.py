"""Parameter types the verbs share: numbers that say what they can mean."""
from __future__ import annotations

import math

import click

# absolute zero in degrees Fahrenheit: no temperature lies at or below it
ABSOLUTE_ZERO_F = -459.67


class FiniteFloatRange(click.FloatRange):
    """`click.FloatRange` that also refuses NaN and infinity, which pass a
    plain range check (every comparison with NaN is false)."""

    name = "finite float range"

    def convert(self, value, param, ctx):
        rv = super().convert(value, param, ctx)
        if not math.isfinite(rv):
            self.fail(f"{value!r} is not a finite number.", param, ctx)
        return rv


POSITIVE = FiniteFloatRange(min=0.0, min_open=True)
