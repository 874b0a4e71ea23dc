"""The diagnosis's typed results: a ranked `Candidate` per effect or set of
effects, a `FamilyDiagnosis` per family of logs and the `Diagnosis` of them
all, each with `to_json()` (the diagnosis.json layout) and the ranking
`.to_pandas()`."""
from __future__ import annotations

import dataclasses
from typing import Optional

import pandas as pd


def selection_step(k: int, change: dict, candidate: str, before_m: float, after_m: float, new_params: int,
                   why: str | None = None, gap_before: float | None = None, alternatives: dict | None = None) -> dict:
    """One selection step as diagnosis.json keeps it: its number `k`; the
    `change` it tried ({"added": effect}, with "freed" or "standing" where
    they apply; {"refined": ...}, {"removed": ...} or {"traded": ...}); the
    `candidate` set that made it; the held-out gap before and after it (m)
    and the gain; the parameters it adds; accepted unless `why` says why
    not (None when accepted); its share of the baseline's held-out gap
    `gap_before` (None where the gain is no share of it: a removal, a trade);
    and the `alternatives` it tried ({set: held-out gap, m})."""
    gain = before_m - after_m
    return {"step": k, **change, "candidate": candidate, "gap_heldout_before_m": before_m,
            "gap_heldout_after_m": after_m, "gain_m": gain, "new_params": new_params, "accepted": why is None,
            "why": why, "share": gain / gap_before if gap_before else None, "alternatives": alternatives or {}}


def added_label(step: dict) -> str:
    """What a selection step added, in words: the effect, and the
    calibration freed beside it where the step's second look took a pair."""
    return f"{step['added']} with {step['freed']} freed" if step.get("freed") else step["added"]


@dataclasses.dataclass
class Candidate:
    """One explanation (an effect, a set of effects, or "none") and its gaps, m.

    `params` and `param_stderr` are {effect: {param: value}} whatever the
    number of effects. `step` is the forward-selection step it was fitted at
    (its number of effects); a set forward selection accepted has `shares`,
    {effect: the held-out gap cut at the step the effect entered, over the
    baseline's held-out gap}, adding up to its `shrink_heldout`. A failed
    candidate (`success` False) has `message` saying which simulation failed
    and why, and no gaps: it is never ranked."""

    effect: str
    effects: list
    n_params: int
    params: dict = dataclasses.field(default_factory=dict)
    param_stderr: dict = dataclasses.field(default_factory=dict)
    gap_before: float = float("nan")
    gap_before_train: Optional[float] = None
    gap_after_train: float = float("nan")
    gap_after_heldout: float = float("nan")
    gap_after_all_fit_per_log: Optional[dict] = None
    shrink_heldout: Optional[float] = None
    score: float = float("nan")
    folds: Optional[list] = None          # {"held_out", "params" (vector), "gap_train", "gap_heldout"}
    screen_share: Optional[dict] = None
    why_not_first: Optional[str] = None
    why: Optional[str] = None             # "none" first: why no effect is needed
    wall_s: Optional[float] = None
    # the times a transient of it (`Effect.scanned`) could be put at (its time scan's
    # positions over the log): each a try of the best of which chance may clear a bar
    looks: int = 1
    probability: Optional[float] = None   # from held-out evidence, over the family's ranked candidates
    # what `probability` was weighed on (`rank.rank_selection`): the separating held-out
    # components and the chance offset (m) against the best, or the presence of its measured effects
    weighed_on: Optional[dict] = None
    implausible: Optional[str] = None     # a value on (or a standard error from) a search bound, or out of range
    step: Optional[int] = None
    shares: Optional[dict] = None
    named: Optional[list] = None          # the events it names (`explanation.explain`)
    calibrations: Optional[dict] = None   # {effect: why it is a calibration within its data sheet's tolerance}
    success: bool = True
    message: str = ""
    # every fold's held-out residual components (`fit.Components`), in fold order:
    # the evidence that tells two candidates apart (not written to the json)
    held_out: Optional[list] = dataclasses.field(default=None, repr=False)

    def to_json(self) -> dict:
        """The diagnosis.json entry: a single effect's parameters without the
        effect's level ({param: value}), as the file has always had them."""
        if not self.success:
            return {"effect": self.effect, "effects": self.effects, "n_params": self.n_params,
                    "success": False, "message": self.message}
        one = len(self.effects) == 1
        out = {"effect": self.effect, "effects": self.effects, "n_params": self.n_params,
               "params": self.params[self.effects[0]] if one else self.params,
               "param_stderr": self.param_stderr[self.effects[0]] if one else self.param_stderr,
               "gap_before": self.gap_before, "gap_after_train": self.gap_after_train,
               "gap_after_heldout": self.gap_after_heldout, "shrink_heldout": self.shrink_heldout,
               "score": self.score, "probability": self.probability}
        if self.effect != "none":
            out.update({"gap_before_train": self.gap_before_train,
                        "gap_after_all_fit_per_log": self.gap_after_all_fit_per_log, "folds": self.folds,
                        "screen_share": self.screen_share, "wall_s": self.wall_s})
        for k in ("why_not_first", "why", "implausible", "step", "shares", "named", "calibrations", "weighed_on"):
            if getattr(self, k) is not None:
                out[k] = getattr(self, k)
        return out


def _ranking_frame(ranking: list, **extra) -> pd.DataFrame:
    rows = []
    for i, c in enumerate(ranking):
        row = {**extra, "rank": i + 1, "effect": c.effect, "n_params": c.n_params,
               "gap_before_m": c.gap_before, "gap_after_train_m": c.gap_after_train,
               "gap_after_heldout_m": c.gap_after_heldout, "shrink_heldout": c.shrink_heldout,
               "score_m": c.score, "probability": c.probability}
        row.update({f"{e}.{k}": v for e, d in c.params.items() for k, v in d.items()})
        rows.append(row)
    return pd.DataFrame(rows)


@dataclasses.dataclass
class FamilyDiagnosis:
    """The where-map, screen, forward selection, ranking and gaps (m) of one
    family of logs. `selection` is `select.Selection.to_json()`: the selected
    effects and their shares, each step's best addition, gain and verdict,
    and why the selection stopped."""

    family: str
    kind: str
    logs: list
    n_elements: Optional[int]
    gap_definition: str
    gap_before: float
    noise_floor: float
    gap_real: bool
    held_out_scheme: str
    screen: dict
    not_applicable: dict
    ranking: list                 # Candidate, best first
    failed: list                  # Candidate with success False: excluded from the ranking
    remaining_unexplained: dict
    gap: dict                     # where-map per log, baseline
    gap_after_best: dict          # where-map per log with the best explanation
    wall_s: float
    selection: dict = dataclasses.field(default_factory=dict)
    steady_floor_m: float = 0.0   # the offset turbulence of sigma_hat leaves by chance (`turbulence.steady_floor`)
    remainder: dict = dataclasses.field(default_factory=dict)   # what the best leaves (`remainder.remainder`)
    # pairs of screened effects these logs cannot tell apart: {"effects": [a, b], "cosine"} (`identify`)
    not_separable: list = dataclasses.field(default_factory=list)
    # the take-up against the reel's reference response (`reel.ReelEvidence.to_json`), None where not measured
    reel: Optional[dict] = None
    # the reference response these logs establish for their reel (`reel.established`), for the fleet file
    reel_established: Optional[dict] = None
    # the effects every simulation carried under the candidates' own: a fleet
    # calibration of the hardware (`fleet`), {} for the data sheets' baseline
    baseline: dict = dataclasses.field(default_factory=dict)
    # {events named, "+"-joined ("none": none): the probability of the explanations naming
    # exactly them}, likeliest first (`rank.named_probability`)
    named_probability: dict = dataclasses.field(default_factory=dict)

    @property
    def success(self) -> bool:
        """Whether every candidate screened in could be simulated."""
        return not self.failed

    @property
    def message(self) -> str:
        return "; ".join(f"{c.effect} failed: {c.message}" for c in self.failed)

    def to_pandas(self) -> pd.DataFrame:
        """The ranking, one row per candidate, parameters as 'effect.param' columns."""
        return _ranking_frame(self.ranking, family=self.family)

    def to_json(self) -> dict:
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        out["ranking"] = [c.to_json() for c in self.ranking]
        out["failed"] = [c.to_json() for c in self.failed]
        return out


@dataclasses.dataclass
class Diagnosis:
    """Every family's diagnosis among the logs given, with the findings in words."""

    logs: list
    families: dict                # name -> FamilyDiagnosis
    findings: list
    scheduler: str
    gap_definition: dict
    noise_factor: float
    param_penalty: float
    max_effects: int
    baseline: str = "datasheet"   # "fleet": families listed in the fleet file started from its calibration

    @property
    def ranking(self) -> list:
        """One family: its ranking; several: each family's best, family first."""
        if len(self.families) == 1:
            return next(iter(self.families.values())).ranking
        return [c for d in self.families.values() for c in d.ranking[:1]]

    @property
    def success(self) -> bool:
        return all(d.success for d in self.families.values())

    @property
    def message(self) -> str:
        return "; ".join(f"{k}: {d.message}" for k, d in self.families.items() if d.message)

    def to_pandas(self) -> pd.DataFrame:
        """Every family's full ranking, one row per candidate."""
        frames = [d.to_pandas() for d in self.families.values()]
        return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()

    def plot(self):
        """A Figure per family: each candidate's held-out gap against the baseline gap and noise floor."""
        from workbench.result_plots import diagnosis_figure
        return diagnosis_figure(self.families)

    def to_json(self) -> dict:
        """The diagnosis.json content (keys as the file has always had them)."""
        fams = {k: d.to_json() for k, d in self.families.items()}
        gap = {log: w for d in self.families.values() for log, w in d.gap.items()}
        if len(fams) == 1:
            ranking = next(iter(fams.values()))["ranking"]
        else:
            ranking = [{"family": k, **d["ranking"][0]} for k, d in fams.items()]
        return {"logs": self.logs, "families": fams, "gap": gap, "ranking": ranking,
                "gap_definition": self.gap_definition, "noise_factor": self.noise_factor,
                "param_penalty": self.param_penalty, "max_effects": self.max_effects,
                "scheduler": self.scheduler, "findings": self.findings, "baseline": self.baseline}
