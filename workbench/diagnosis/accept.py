"""The rule a change to the selected set is accepted by: what it explains of
the held-out gap against the noise floor (widened by what a real random
motion explains by chance along the change's pattern) and the parameter
penalty (`acceptance`, `widened`); which of explanations the logs cannot tell
apart comes first (`choose`, `simplest`); the shares of a set's gap."""
from __future__ import annotations

import math
from typing import Callable

from scipy.special import erfcinv

from solver.effects import EFFECTS
from workbench.diagnosis.explanation import event_count
from workbench.diagnosis.result import Candidate
from workbench.diagnosis.setup import NOISE_FACTOR, PARAM_PENALTY


def explained(gain: float, current_gap: float) -> float:
    """The part of the held-out gap `current_gap` (m) that a step cutting it
    by `gain` explains: sqrt(current^2 - after^2), gaps being RMS and
    independent parts adding in quadrature."""
    after = current_gap - gain
    return math.sqrt(max(current_gap ** 2 - after ** 2, 0.0)) if gain > 0 else 0.0


def acceptance(gain: float, n_new: int, current_gap: float, floor: float) -> str | None:
    """Why an addition that cuts the held-out gap `current_gap` by `gain` (m)
    with `n_new` new parameters is refused, or None when it is accepted.

    The noise: what the addition explains (`explained`, in quadrature) must
    beat `NOISE_FACTOR` x the noise floor, the rule a gap itself is real by.
    Not the plain difference of the gaps: beside a model-form remainder a few
    times the noise, an effect whose own signature is three times the noise
    cuts the RMS by barely one noise floor, and would be refused wherever
    anything else is left unexplained. The parameter penalty stays on the
    plain cut: each parameter must buy `PARAM_PENALTY` of the gap left."""
    part = explained(gain, current_gap)
    noise, penalty = NOISE_FACTOR * floor, PARAM_PENALTY * n_new * current_gap
    if part <= noise:
        return (f"explains {part:.4f} m of the held-out gap {current_gap:.4f} m (cutting it by {gain:.4f} m), "
                f"not more than {NOISE_FACTOR:g} x the noise floor ({noise:.4f} m)")
    if gain <= penalty:
        return (f"cuts the held-out gap by {gain:.4f} m, not more than the parameter penalty ({PARAM_PENALTY:g} x "
                f"{n_new} new parameter(s) x the held-out gap {current_gap:.4f} m = {penalty:.4f} m)")
    return None


def bar(current_gap: float, n_new: int, floor: float) -> float:
    """The held-out gap (m) below which a change of `n_new` new parameters
    from `current_gap` is accepted (`acceptance`, no chance widening)."""
    return min(math.sqrt(max(current_gap ** 2 - (NOISE_FACTOR * floor) ** 2, 0.0)),
               current_gap * (1 - PARAM_PENALTY * n_new))


def chance_quantile(tried: int) -> float:
    """How many standard deviations of its chance gain the best of `tried`
    additions must clear so that a step takes one by chance no more often
    than one addition clears `NOISE_FACTOR` of them (a two-sided normal tail,
    4.6 % at 2): Sidak's quantile, the best of several being the largest of
    their chance gains (2.0 for one, 2.7 for seven)."""
    alpha = math.erfc(NOISE_FACTOR / math.sqrt(2.0))
    return math.sqrt(2.0) * float(erfcinv(1.0 - (1.0 - alpha) ** (1.0 / max(tried, 1))))


def widened(floor: float, chance: Callable | None, before: Candidate | None, after: Candidate | None,
            tried: int = 1) -> float:
    """The noise floor a change from the set `before` to `after` (None: the
    baseline) must beat, chosen as the best of `tried` additions: `floor`,
    and where a real random motion is measured what it explains along the
    change's pattern by chance (`chance(before, after)`, m,
    `turbulence.RandomEffect.chance_offset`) at `chance_quantile(tried)`
    standard deviations over `NOISE_FACTOR`'s, in quadrature; so that
    `NOISE_FACTOR` x it is hypot(NOISE_FACTOR x floor, z x chance). A change
    that adds a transient at a scanned time (`Effect.scanned`) was tried at
    each of its `Candidate.looks` times too: the largest burst of a random
    motion is the one a scan finds."""
    if chance is None:
        return floor
    added = set(after.effects if after else ()) - set(before.effects if before else ())
    if after is not None and any(EFFECTS[e].scanned for e in added):
        tried *= after.looks
    return math.hypot(floor, chance(before, after) * chance_quantile(tried) / NOISE_FACTOR)


def choose(fits: list, floor: float, prior: dict | None = None) -> Candidate:
    """The addition a step takes among `fits`: of those whose held-out gap
    is within the noise floor `floor` of the best (the data cannot tell them
    apart), the one that names the fewest events (calibrations within their
    data sheets' tolerance are no event beside one, together one alone:
    `explanation.event_count`), then has the fewest parameters, then the
    smallest gap."""
    least = min(c.gap_after_heldout for c in fits)
    similar = [c for c in fits if c.gap_after_heldout <= least + floor]
    return min(similar, key=lambda c: simplest(c, prior))


def simplest(c: Candidate, prior: dict | None = None) -> tuple:
    """The order in which the simplest of explanations the logs cannot tell
    apart comes first: fewest events (`explanation.event_count`), then
    fewest parameters, then the smallest held-out gap."""
    return event_count(c.effects, c.params, prior), c.n_params, c.gap_after_heldout


def rescaled(shares: dict, gap_after: float, gap_before: float) -> dict:
    """`shares` ({effect: share}) in their proportions, scaled to add up to
    the shrink 1 - gap_after / gap_before of the set they belong to."""
    total = 1.0 - gap_after / gap_before if gap_before else 0.0
    return {x: v * total / sum(shares.values()) for x, v in shares.items()} if sum(shares.values()) else shares
