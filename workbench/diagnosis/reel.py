"""The reel lag from the reel's own channel.

The engagement baseline prescribes the logged payout (`[model] reel =
"from_log"`): whatever the reel did, the simulated hose is paid out as the
log says, so a late or sluggish reel leaves nothing in the gap, and the
`reel_lag` effect (a drum drive's dead time, lag and hold-back) has nothing
to be fitted to there. Its evidence is the payout itself, against the
receiver's closure: the take-up's response to it (`flighttest.metrics.reel`).

The data sheets give the reel's drum and mode, not its response. The program's
own engagements of the reel do: the response fitted on them, with the misfit
each of them leaves held out (the everyday misfit: the hose's slack and its
waves, which the response's form does not hold), is written to the fleet
file (`fleet.reel_references`) by the same run that writes the fleet
calibrations, and is the reference in either baseline, as no data sheet says
otherwise. A log whose take-up misses the reference response by more than
`NOISE_FACTOR` times the everyday misfit (RMS over its logs) carries a reel
event: its reel took up the hose otherwise than the program's reel does.

The probability that it does, the share of the selected set's weight the
set with the reel event takes (`rank.with_random_share`), is
Phi(sqrt(n) ln(ratio / NOISE_FACTOR)): the log of a ratio of two RMS values
over n independent pieces each has a standard error of about 1/sqrt(n), and
the misfit is smooth over the reel response's period, so n is the contact's
length over that period. Its share of the gap is zero: the payout is
prescribed, so it cuts no part of the hose's gap.
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from flighttest import LogError
from flighttest.metrics.reel import RESPONSE_KEYS, ReelResponse, fit_reel_response, held_out_misfit, misfit
from flighttest.reel import reel_track
from flighttest.residual import rms
from workbench.diagnosis.result import Candidate, selection_step
from workbench.diagnosis.select import Selection
from workbench.diagnosis.setup import NOISE_FACTOR

EFFECT = "reel_lag"


@dataclasses.dataclass
class ReelEvidence:
    """A family's take-up against its reel's reference response: each log's
    RMS misfit (m) and own fitted response, the ratio of their RMS to the
    reference's everyday misfit, the independent pieces `n` and the
    probability that the reel responded otherwise than the reference."""

    reel: str
    reference: dict               # the fleet's: its response, everyday misfit (m) and logs
    misfit_m: dict                # {log: RMS misfit under the reference}
    own: dict                     # {log: its own fitted response}
    ratio: float
    n_pieces: float
    presence: float

    @property
    def event(self) -> bool:
        return self.ratio > NOISE_FACTOR

    def why(self) -> str:
        ref = self.reference
        verdict = "beyond" if self.event else "within"
        return (f"the take-up misses reel {self.reel}'s reference response (fitted on {', '.join(ref['logs'])}) "
                f"by {rms(list(self.misfit_m.values())):.3f} m RMS, {self.ratio:.2f} x its everyday misfit "
                f"{ref['everyday_misfit_m']:.3f} m: {verdict} {NOISE_FACTOR:g} x")

    def to_json(self) -> dict:
        return {"reel": self.reel, "reference": self.reference, "misfit_m": self.misfit_m, "own": self.own,
                "ratio": self.ratio, "n_pieces": self.n_pieces, "probability": self.presence,
                "event": self.event, "why": self.why()}


def reel_tracks(paths, recs) -> dict:
    """{log stem: its reel track's arrays} for the logs at `paths` (read in
    `recs`) that have one: what `established` and `reel_evidence` measure."""
    out = {}
    for p in paths:
        try:
            out[Path(p).stem] = reel_track(recs[p]).arrays()
        except LogError:
            continue
    return out


def established(tracks: dict, reel: str) -> dict | None:
    """The reference response a family of engagement logs establishes for its
    `reel` (`fleet.reel_references`): fitted on all its reel `tracks`
    (`reel_tracks`), with the everyday misfit (`metrics.reel.held_out_misfit`);
    None when there are none."""
    if not tracks:
        return None
    response, everyday = held_out_misfit(list(tracks.values()))
    return {"reel": reel, **dataclasses.asdict(response), "everyday_misfit_m": everyday, "logs": sorted(tracks)}


def reel_evidence(tracks: dict, reel: str, reference: dict) -> ReelEvidence | None:
    """The family's take-up, its reel `tracks` (`reel_tracks`), against
    `reference` (a `fleet.reel_references` entry for `reel`); None when there
    are no tracks."""
    if not tracks:
        return None
    ref = ReelResponse(**{k: reference[k] for k in RESPONSE_KEYS})
    m = {log: misfit(ref, *tr) for log, tr in tracks.items()}
    own = {log: dataclasses.asdict(fit_reel_response([tr])) for log, tr in tracks.items()}
    ratio = rms(list(m.values())) / reference["everyday_misfit_m"]
    period = 2.0 * math.pi / ref.natural_frequency_rad_s
    n = sum(float(tr[0][-1] - tr[0][0]) for tr in tracks.values()) / period
    z = math.sqrt(n) * math.log(ratio / NOISE_FACTOR) if ratio > 0 else -math.inf
    return ReelEvidence(reel, dict(reference), m, own, ratio, n, 0.5 * math.erfc(-z / math.sqrt(2.0)))


def variant(base: Candidate, evidence: ReelEvidence) -> Candidate:
    """`base` with the reel event: the same fit and gaps (the payout is
    prescribed, so the hose's gap is the base's), one more parameter (the
    response the reel channel measured), a zero share of the gap."""
    return dataclasses.replace(base, effect="+".join(list(base.effects) + [EFFECT]),
                               effects=list(base.effects) + [EFFECT], n_params=base.n_params + 1,
                               params={**base.params, EFFECT: {}}, param_stderr={**base.param_stderr, EFFECT: {}},
                               shares={**(base.shares or {}), EFFECT: 0.0} if base.shares is not None else None,
                               why=None, why_not_first=None, named=None, calibrations=None, probability=None)


def _simulated_form(c: Candidate) -> tuple:
    """`c`'s effects but turbulence, with their fitted values: turbulence
    joined to a set, or the set it joined, share it."""
    return tuple((e, tuple(sorted(c.params.get(e, {}).items()))) for e in c.effects if e != "turbulence")


def with_reel(sel: Selection, none: Candidate, evidence: ReelEvidence) -> Selection:
    """`sel` with the reel event's candidates: the selected set with it, and
    `none` with it, and so every fitted candidate that is either with or
    without turbulence (the set with the turbulence refused, the set before
    the turbulence joined it, turbulence alone), so that every combination
    of the two measured effects on them is ranked; the first of them
    selected when the evidence is an event. A step of its own, accepted
    or refused from the reel channel, not from the gap (it cuts none of it)."""
    tops = [none] if sel.chosen is None else [sel.chosen, none]
    forms = {_simulated_form(c) for c in tops}
    bases = tops + [c for c in sel.fitted if c is not sel.chosen and _simulated_form(c) in forms]
    extra = [variant(c, evidence) for c in bases]
    current = (sel.chosen or none).gap_after_heldout
    k = sel.steps[-1]["step"] + 1 if sel.steps else 1
    step = selection_step(k, {"added": EFFECT}, extra[0].effect, current, current, 1,
                          why=None if evidence.event else evidence.why(), gap_before=none.gap_before)
    for c in extra:
        c.step = k
    if not evidence.event:
        for c in extra:
            c.why_not_first = f"adding the reel lag refused: {evidence.why()}"
        return dataclasses.replace(sel, fitted=sel.fitted + extra, steps=sel.steps + [step])
    return dataclasses.replace(sel, chosen=extra[0], fitted=sel.fitted + extra, steps=sel.steps + [step],
                               stopped=f"{sel.stopped}; then the reel lag accepted from the reel channel")
