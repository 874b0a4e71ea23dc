"""`workbench diagnose --selftest --proving-ground independent`: the diagnosis
run blind on proving-ground logs, scored against their truth.

Families (`plan`): one effect per log (single), two or three at once
(multi), one at a fraction of its size, near the instruments' noise
(subtle), and none withheld (null: every event named there is a false alarm).

Figures: top-1 (the top explanation's effects are exactly the true set),
recall (the share of the true effects inside the top explanation), held-out
shrink of the top explanation, each per effect and per test kind, and a
confusion matrix (true set -> top explanation). A log whose true set holds an
effect the diagnosis cannot rank on that log (not applicable there: a gust
on a trail or an engagement, a reel lag where the fleet file holds no
reference response of its reel) counts as a
miss in the plain figures and is also counted apart ("nameable" figures), so
neither hides the other.

The figures compare the true set with the events the top explanation names
(`Candidate.named`, `diagnosis.explanation`), and each row keeps the full
explanation. A model-form effect (the tracked point on the drogue) is no
event of the flight: the generator's drogue always differs from the model's
in its reference point (`physics.CP_OFFSET_M`, `CG_SHARE`), so naming it is
neither a hit nor a miss. Nor is a calibration within a data sheet's
tolerance, beside an event beyond it or alone (`events`: alone, the
diagnosis names it and says the gap may be the hardware's own spread about
its data sheet, `findings`, which claims no event of the flight): the
generator scatters the hardware about its data sheets (`physics.SPREAD`) as
the real hardware is scattered.
Where that scatter falls beyond the data sheet's tolerance (the registry's
`Param.tolerance`: a drogue C_L drawn up to 30 % off against its 25 %), the
hardware is off its data sheet, and that is an effect of the flight: the
true set holds it (`off_sheet`), to be named like a withheld one.

A miss is also told apart by what the logs could say (`truth_fit`): the true
model in the diagnosis's terms (the true events it can fit, the scattered
hardware's calibrations, the top's calibrations and model form) fitted from
the values the generator drew and scored held out like any candidate. Where
it explains the log better than the top explanation by more than the noise
floor, the selection missed a better explanation; where it does not, the
logs do not prefer the truth under the model's form (the form differences or
a near-parallel effect take its place), and no rule of the selection could
have named it. `rescore` does it again on a campaign's kept logs.

Each row keeps its ranked candidates' evidence (`evidence`), what each
probability was weighed on included: `reweigh` weighs a campaign's
probabilities again by another rule and sums its figures again.
"""
from __future__ import annotations

import json
import math
import tempfile
import time
from collections import Counter
from typing import Callable
from pathlib import Path

import numpy as np

from flighttest import read_record
from flighttest.residual import residual
from solver.chain import DivergenceError
from solver.effects import EFFECTS
from workbench.diagnosis.evaluate import evaluate, gap, record
from workbench.diagnosis.explanation import within_tolerance
from workbench.diagnosis.fit import ordered
from workbench.diagnosis.rank import diagnose_family, probabilities, with_random_share
from workbench.diagnosis.score import score_candidate
from workbench.errors import SimulationFailed
from workbench.parallel import Mapper
from workbench.proving import FAMILIES
from workbench.diagnosis.result import Candidate
from workbench.diagnosis.setup import DEFAULT_ELEMENTS, NOISE_FACTOR, Setup, applicable, calibrated_params
from workbench.proving.generate import KIND_EFFECTS, generate
from workbench.simlog import result_to_record

MIN_EACH = 3   # every effect at least this often in the one-at-a-time family (`plan`)


def plan(n: int, family: str, seed: int) -> list[tuple[str, tuple, int]]:
    """n (kind, effects, seed) draws. single: every flight event in turn (an
    order shuffled once by `seed`), each on the kind that can carry it that
    has seen it least, then that is used least so far: every effect appears
    as often as n allows, at least `MIN_EACH` times from n = `MIN_EACH` x the
    number of events (gust, bow wave and reel lag act on one kind only, and
    kinds in turn would leave them one or two logs in 48), on each kind that
    can carry it, and the kinds stay as even as that leaves them; multi:
    kinds in turn, 2-3 distinct effects of the kind at random; subtle: the
    single family's plan, each log's effect at a fraction of its size
    (`generate.shrink`); null: kinds in turn, no event withheld (the form
    and the nuisance only): what the diagnosis names there is a false alarm."""
    if family not in FAMILIES:
        raise ValueError(f"family must be one of {FAMILIES}, got {family!r}")
    rng = np.random.default_rng([seed, FAMILIES.index(family)])   # the families draw apart
    kinds = list(KIND_EFFECTS)
    shuffled = {k: [KIND_EFFECTS[k][j] for j in rng.permutation(len(KIND_EFFECTS[k]))] for k in kinds}
    seeds = rng.integers(1, 2 ** 31 - 1, size=n)
    if family == "null":
        return [(kinds[i % len(kinds)], (), int(s)) for i, s in enumerate(seeds)]
    if family == "multi":
        return [(kinds[i % len(kinds)],
                 tuple(sorted(rng.choice(shuffled[kinds[i % len(kinds)]], size=int(rng.integers(2, 4)),
                                         replace=False).tolist())), int(s)) for i, s in enumerate(seeds)]
    events = sorted({e for effs in KIND_EFFECTS.values() for e in effs})
    order = [events[j] for j in rng.permutation(len(events))]
    used, pairs = Counter(), Counter()
    out = []
    for i, s in enumerate(seeds):
        effect = order[i % len(order)]
        kind = min((k for k in kinds if effect in KIND_EFFECTS[k]),
                   key=lambda k: (pairs[k, effect], used[k], kinds.index(k)))
        used[kind] += 1
        pairs[kind, effect] += 1
        out.append((kind, (effect,), int(s)))
    return out


# the form's hardware scatter (`physics.draw_form`: factors on the data sheet's
# values) as the registry's effect parameters it would be calibrated by
SCATTER = {"drogue_cl_factor": ("drogue_lift", "scale"), "drogue_cd_factor": ("drogue_drag", "scale"),
           "EI_factor": ("hose_stiffness", "bending")}


def off_sheet(form: dict) -> set:
    """The effects whose hardware `form` scattered beyond the data sheet's
    tolerance about its value (a factor f off 1 by more than the tolerance:
    the diagnosis's own test, `explanation.within_tolerance`)."""
    return {effect for key, (effect, name) in SCATTER.items()
            if key in form and not within_tolerance(EFFECTS[effect].params[name], form[key], 1.0)}


def signature(path: Path, reference) -> dict:
    """How visible the withheld effects are in the log at `path`: the one
    comparison (`flighttest.residual`, signature components included) of the
    log with `reference`, the same flight without them (`generate(...,
    reference=True)`). Its gap holds their signature and the instruments'
    noise; `floor_m` is that noise's floor, and `detectable` the diagnosis's
    own rule for a gap that is real, gap > `NOISE_FACTOR` x floor. A log
    whose effects leave less than that carries nothing any method could name:
    it is scored like every other, and counted apart."""
    log = read_record(path)
    R = residual(log, result_to_record(reference, log, ors_dt=None))
    g, floor = gap(R.r), gap(R.floor)
    return {"signature_m": math.sqrt(max(g ** 2 - floor ** 2, 0.0)), "signature_gap_m": g,
            "signature_floor_m": floor, "detectable": bool(g > NOISE_FACTOR * floor)}


def truth_start(truth: dict, events: list, model_form: dict) -> dict:
    """{effect: {param: value}} a fit of the true set starts from: each
    calibrated parameter of `events` (and of the scattered hardware's
    calibrations among them) at the generator's draw times the hardware's
    scatter on the same factor (`SCATTER`: the truth model scales the
    scattered value), its off value where neither touches it, clipped to the
    search range; the model-form effects at `model_form`'s values."""
    factor = {eff_name: truth["form"][key] for key, eff_name in SCATTER.items() if key in truth.get("form", {})}
    out = {}
    for e, name, p in calibrated_params(tuple(events)):
        v = float(truth["params"].get(e, {}).get(name, p.off)) * factor.get((e, name), 1.0)
        out.setdefault(e, {})[name] = min(max(v, p.search[0]), p.search[1])
    return {**out, **{e: dict(v) for e, v in model_form.items()}}


def truth_fit(path: Path, truth: dict, true: set, top: Candidate, floor: float, setup: Setup) -> dict | None:
    """The true set's own fit on the log at `path` (the module's note): the
    true events the diagnosis can fit to this log (`setup.applicable`: none
    with nothing to fit to a time history, a random motion, nor one not
    applicable to the kind) in place of the `top` explanation's events, with
    the calibrations of the hardware the generator scattered (`SCATTER`, any
    the kind is sensitive to: no events, but the truth model has them) and
    the top's own calibrations and model-form effects; started at the truth
    (`truth_start`), scored held out on the diagnosis's folds, and `better`
    when its held-out gap is below the top's by more than the noise
    `floor`. A top that holds a random motion is compared by its
    deterministic set, refitted from the top's values (a random motion's
    gap is its statistics', no like-for-like evidence: `rank`). None when
    the true events are none it can fit (a null log's truth, no event, is
    fitted as its calibrations and model form)."""
    rec = record(str(path))   # read once per worker: the diagnosis read it just before
    kind, case = rec.info.test_kind, setup.case_for(rec)
    events = sorted(e for e in true if not applicable(e, kind, case, rec))
    if true and not events:
        return None
    model_form = {e: top.params.get(e, {}) for e in top.effects if EFFECTS[e].model_form}
    cals = sorted(({e for e, _ in SCATTER.values() if not applicable(e, kind, case, rec)}
                   | set(top.calibrations or {})) - set(events))
    effects = ordered(events + cals + list(model_form))
    if not effects:
        return None
    w = truth_start(truth, events + cals, model_form)
    c = score_candidate(([str(path)], effects, setup, {"folds": [w, w], "all": w}))
    if not c.success:
        return {"set": c.effect, "failed": c.message}
    det = ordered(e for e in top.effects if not applicable(e, kind, case, rec))
    against = top.gap_after_heldout
    if len(det) < len(top.effects):
        p = {e: top.params.get(e, {}) for e in det}
        refit = score_candidate(([str(path)], det, setup, {"folds": [p, p], "all": p})) if det else None
        # a refit that fails to simulate (it did not in the diagnosis) leaves the top's own gap
        against = (gap(evaluate(str(path), {}, setup).r) if refit is None
                   else refit.gap_after_heldout if refit.success else against)
    return {"set": c.effect, "params": c.params, "gap_heldout": c.gap_after_heldout, "top_gap_heldout": against,
            "better": bool(c.gap_after_heldout < against - floor)}


def rescore(r: dict, workers: int | None = None) -> dict:
    """The campaign `r` (a `run_campaign` result, as read back from
    proving-<family>.json) with every miss's true-set fit (`truth_fit`) done
    again on its kept logs (`logs_dir`) from what its rows recorded, and its
    figures summed again; the diagnoses themselves are not re-run."""
    rows = [dict(row) for row in r["rows"]]
    misses = [row for row in rows if not row["correct"] and "diagnose_failed" not in row]
    jobs = [(Path(r["logs_dir"]) / row["log"], row, r["n_elements_diagnosis"]) for row in misses]
    with Mapper(workers) as mapper:
        fits = mapper(_refit, jobs)
    for row, fit in zip(misses, fits):
        row["truth_fit"] = fit
    return _summed_again(r, rows)


def reweigh(r: dict, rule: Callable = probabilities) -> dict:
    """The campaign `r` with its probabilities weighed again by `rule` (of
    `rank.probabilities`' arguments: the held-out gaps, parameter counts,
    noise floor, separating components and chance offsets of the
    deterministic candidates) from what each ranked candidate's was weighed
    on (`weighed_on`), shared with the measured effects as the diagnosis
    shares them (`rank.with_random_share`), and its figures summed again: a
    rule of the probabilities read against a campaign's fits without
    fitting them again. A row whose candidates lack it is left as it was."""
    rows = [_reweighed(dict(row), rule) if row.get("candidates")
            and all(c.get("weighed_on") for c in row["candidates"]) else row for row in r["rows"]]
    return _summed_again(r, rows)


def _reweighed(row: dict, rule: Callable) -> dict:
    kept = row["candidates"]
    ranked = [Candidate(c["effect"], [] if c["effect"] == "none" else c["effect"].split("+"), c["n_params"],
                        params=c["params"], gap_after_heldout=c["gap_heldout"]) for c in kept]
    det = [(c, k["weighed_on"]) for c, k in zip(ranked, kept) if "presence" not in k["weighed_on"]]
    presence = {e: p for k in kept for e, p in k["weighed_on"].get("presence", {}).items()}
    weights = rule([c.gap_after_heldout for c, _ in det], [c.n_params for c, _ in det], row["noise_floor"],
                   [w["separating_components"] for _, w in det], [w["chance_m"] for _, w in det])
    with_random_share(ranked, {id(c): x for (c, _), x in zip(det, weights)}, presence)
    row["candidates"] = [dict(k, probability=c.probability) for c, k in zip(ranked, kept)]
    row["top_probability"] = ranked[0].probability
    row["top_named_probability"] = sum(k["probability"] for k in row["candidates"] if k["events"] == kept[0]["events"])
    return row


def _summed_again(r: dict, rows: list) -> dict:
    """The campaign `r` with `rows` in place of its own and its figures summed again."""
    keep = {k: r[k] for k in ("generate_failed", "generator", "seed", "n_elements_diagnosis", "wall_s", "logs_dir")}
    return {**summarise(rows, r["family"]), **keep, "rows": rows}


def _refit(job):
    path, row, n_elements = job
    top = Candidate(row["top_explanation"], list(row["top_effects"]), 0, params=row["top_params"],
                    gap_after_heldout=row["gap_after_heldout"], calibrations=row["top_calibrations"])
    return truth_fit(path, row, _true_set(row), top, row["noise_floor"], Setup(n_elements))


def events(c: Candidate) -> frozenset:
    """The events of the flight an explanation claims: what it names
    (`Candidate.named`) less its calibrations within a data sheet's
    tolerance, which it names only where nothing else is left."""
    return frozenset(c.named or ()) - set(c.calibrations or {})


def evidence(c: Candidate) -> dict:
    """A ranked candidate as a row keeps it: what it names and the evidence it
    was ranked on (held-out gap, score, fitted values with their standard
    errors, the implausibility flag, probability and what it was weighed on),
    so that a rule of the ranking (plausibility, probabilities) can be read
    against a campaign's fits without fitting them again."""
    return {"effect": c.effect, "events": _spelled(events(c)), "n_params": c.n_params,
            "gap_heldout": c.gap_after_heldout, "score": c.score, "probability": c.probability,
            "implausible": c.implausible, "step": c.step, "params": c.params, "param_stderr": c.param_stderr,
            "weighed_on": c.weighed_on}


def _spelled(effects: set) -> str:
    """A set of events as the rows and the confusion matrix spell it."""
    return "+".join(sorted(effects)) or "none"


def _true_set(row: dict) -> set:
    return set() if row["truth"] == "none" else set(row["truth"].split("+"))


def _recall(true: set, named: set) -> float | None:
    """The share of the true events named; None where none was withheld
    (a null log: what it names is a false alarm, counted by top-1)."""
    return len(true & named) / len(true) if true else None


def _mean(values) -> float | None:
    v = [x for x in values if x is not None]
    return float(np.mean(v)) if v else None


def run_one(job) -> dict:
    """Generate one log and diagnose it blind (runs in a worker)."""
    kind, effects, seed, out_dir, n_elements, family = job
    t = time.perf_counter()
    try:
        path, truth, reference = generate(kind, list(effects), seed, Path(out_dir), reference=True,
                                          subtle=family == "subtle")
    except DivergenceError as exc:
        # the truth model itself failed: no log, reported apart (not scored)
        return {"kind": kind, "effects": list(effects), "seed": seed, "generate_failed": str(exc)}
    truth = {**truth, **signature(path, reference)}
    true = set(effects) | off_sheet(truth["form"])
    t_gen = time.perf_counter() - t
    try:
        d = diagnose_family([str(path)], Setup(n_elements), mapper=Mapper(workers=1))
    except SimulationFailed as exc:
        # the diagnosis's own baseline failed on this log: it names nothing, a miss,
        # counted in the figures and listed with its reason
        return {**truth, "log": path.name, "truth": _spelled(true), "top": "failed",
                "diagnose_failed": str(exc), "correct": False, "recall": _recall(true, set()), "nameable": True,
                "unnameable": [],
                "shrink_heldout": 0.0, "generate_s": t_gen, "diagnose_s": time.perf_counter() - t - t_gen}
    top = d.ranking[0]
    named = events(top)
    unnameable = sorted(e for e in true if e in d.not_applicable)
    # a miss: could the logs have said so? (the true set's own fit; a hit needs none)
    t_fit = time.perf_counter()
    oracle = None if named == true else truth_fit(path, truth, true, top, d.noise_floor, Setup(n_elements))
    t_fit = time.perf_counter() - t_fit
    return {**truth, "log": path.name, "truth": _spelled(true), "top": _spelled(named),
            "top_explanation": top.effect, "top_effects": list(top.effects), "top_params": top.params,
            "top_calibrations": top.calibrations, "top_probability": top.probability,
            # the probability of those events: every ranked explanation claiming just them
            "top_named_probability": sum(c.probability or 0.0 for c in d.ranking if events(c) == named),
            "top_implausible": top.implausible,
            "correct": named == true, "recall": _recall(true, named),
            "nameable": not unnameable, "unnameable": unnameable,
            "gap_before": top.gap_before, "gap_after_heldout": top.gap_after_heldout,
            "shrink_heldout": top.shrink_heldout, "noise_floor": d.noise_floor,
            "candidates": [evidence(c) for c in d.ranking],
            "selected": d.selection.get("effects"), "truth_fit": oracle, "truth_fit_s": t_fit,
            "generate_s": t_gen, "diagnose_s": d.wall_s}


def _reliability(rows: list) -> dict:
    """How far the probability of what the top explanation names is to be
    trusted: its mean over the logs, and its Brier score as a forecast that
    the top is right, mean (p - right)^2, beside a constant forecast of the
    top-1 rate's, rate (1 - rate): lower than that, the probabilities say
    more than the rate alone. The probability of the events named (summed
    over the explanations naming them) where every row has it, else the top
    explanation's own (rows written before it was recorded); logs whose
    diagnosis failed carry none."""
    scored = [r for r in rows if r.get("top_probability") is not None]
    if not scored:
        return {}
    key = "top_named_probability" if all(r.get("top_named_probability") is not None for r in scored) \
        else "top_probability"
    p = np.array([r[key] for r in scored], float)
    right = np.array([r["correct"] for r in scored], float)
    rate = float(np.mean(right))
    return {"probability_of": "the events named" if key == "top_named_probability" else "the top explanation",
            "top_probability_mean": float(np.mean(p)), "brier_top": float(np.mean((p - right) ** 2)),
            "brier_constant": rate * (1.0 - rate)}


def _missed(rows: list) -> dict:
    """The misses by what the true set's own fit (`truth_fit`) says: the
    truth explains the log better held out by more than the noise floor
    (the selection missed it), or not (the logs do not prefer it), or no fit
    (no deterministic event it could rank, a fit that failed, a row written
    before the fit was recorded); the top-1 rate where the logs prefer the
    truth (hits over hits and the misses of the first kind)."""
    missed = [r.get("truth_fit") for r in rows if not r["correct"]]
    better = sum(bool(f and f.get("better")) for f in missed)
    no_better = sum(bool(f and "better" in f and not f["better"]) for f in missed)
    hits = len(rows) - len(missed)
    return {"n_missed_truth_better": better, "n_missed_truth_no_better": no_better,
            "n_missed_truth_unfitted": len(missed) - better - no_better,
            "top1_truth_preferred": hits / (hits + better) if hits + better else None}


def _figures(rows: list) -> dict:
    if not rows:
        return {"n": 0}
    shr = np.array([r["shrink_heldout"] for r in rows], float)
    nameable = [r for r in rows if r["nameable"]]
    null = [r for r in rows if r["truth"] == "none"]
    seen = [r for r in rows if r["detectable"]]
    return {"n": len(rows), **_reliability(rows), "top1": float(np.mean([r["correct"] for r in rows])),
            "recall": _mean(r["recall"] for r in rows),
            "median_shrink": float(np.median(shr)), "share_shrink_ge_70pct": float(np.mean(shr >= 0.7)),
            "n_nameable": len(nameable),
            "top1_nameable": _mean(r["correct"] for r in nameable),
            "n_detectable": len(seen),
            "top1_detectable": _mean(r["correct"] for r in seen),
            "recall_detectable": _mean(r["recall"] for r in seen),
            # no event withheld (the null family): the share that names none, 1 - the false-alarm rate
            "n_no_event": len(null), "no_event_named_none": _mean(r["correct"] for r in null),
            **_missed(rows)}


def summarise(rows: list, family: str) -> dict:
    """The campaign's figures: overall, per effect (every log carrying it),
    per test kind, and the confusion matrix {true set: {top: count}}."""
    effects = sorted({e for r in rows for e in r["effects"]})
    confusion: dict = {}
    for r in rows:
        confusion.setdefault(r["truth"], {}).setdefault(r["top"], 0)
        confusion[r["truth"]][r["top"]] += 1
    return {"family": family, **_figures(rows),
            "by_effect": {e: _figures([r for r in rows if e in r["effects"]]) for e in effects},
            "by_kind": {k: _figures([r for r in rows if r["kind"] == k]) for k in KIND_EFFECTS
                        if any(r["kind"] == k for r in rows)},
            "confusion": confusion, "n_diagnose_failed": sum("diagnose_failed" in r for r in rows),
            "seconds_per_log": float(np.mean([r["generate_s"] + r["diagnose_s"] for r in rows])) if rows else None}


def run_campaign(n: int, family: str = "single", seed: int = 2026, n_elements: int | None = None,
                 workers: int | None = None, scheduler: str | None = None, out_dir: Path | None = None,
                 progress: Callable | None = None) -> dict:
    """Generate `n` proving-ground logs of `family` under `out_dir` (or a
    temporary folder), diagnose each blind; the figures and one row per log."""
    t = time.perf_counter()
    logs = Path(tempfile.mkdtemp(prefix="proving-") if out_dir is None else out_dir) / f"logs-{family}"
    logs.mkdir(parents=True, exist_ok=True)
    jobs = [(k, e, s, str(logs), n_elements or DEFAULT_ELEMENTS, family) for k, e, s in plan(n, family, seed)]
    with Mapper(workers, scheduler) as mapper:
        rows = mapper(run_one, jobs, progress=progress)
    failed = [r for r in rows if "generate_failed" in r]
    rows = [r for r in rows if "generate_failed" not in r]
    return {**summarise(rows, family), "generate_failed": failed, "generator": "independent", "seed": seed,
            "n_elements_diagnosis": n_elements or DEFAULT_ELEMENTS, "wall_s": time.perf_counter() - t,
            "logs_dir": str(logs), "rows": rows}


def _pct(v):
    return "-" if v is None else f"{100 * v:.0f} %"


def text(r: dict) -> str:
    """The campaign in a few lines a reader can check against the JSON."""
    lines = [f"proving ground (independent form), family {r['family']}: {r['n']} logs, "
             f"top-1 {_pct(r['top1'])}, recall {_pct(r['recall'])}, median held-out shrink "
             f"{_pct(r['median_shrink'])}; nameable logs {r['n_nameable']}, top-1 {_pct(r['top1_nameable'])}; "
             f"logs whose effects are above their noise {r['n_detectable']}, top-1 {_pct(r['top1_detectable'])}, "
             f"recall {_pct(r['recall_detectable'])}; "
             f"{r['seconds_per_log'] or 0:.0f} s per log, {r['wall_s']:.0f} s in all"
             + (f"; the probability of {r['probability_of']} {r['top_probability_mean']:.2f} on average, its "
                f"Brier score "
                f"{r['brier_top']:.3f} (a constant forecast of the top-1 rate: {r['brier_constant']:.3f})"
                if "brier_top" in r else "")
             + (f"; {len(r['generate_failed'])} truth simulations failed, not scored" if r["generate_failed"] else "")
             + (f"; the diagnosis's baseline failed on {r['n_diagnose_failed']} (counted as misses)"
                if r.get("n_diagnose_failed") else "")]
    if r.get("n_no_event"):
        lines.append(f"  no event withheld: {r['n_no_event']} logs, named none in {_pct(r['no_event_named_none'])} "
                     f"(false alarms {_pct(1.0 - r['no_event_named_none'])})")
    if "n_missed_truth_better" in r:
        lines.append(f"  misses: {r['n_missed_truth_better']} where the true set, fitted from its own values, "
                     f"explains the log better held out by more than the noise floor (the selection missed it); "
                     f"{r['n_missed_truth_no_better']} where it does not (the logs do not prefer it under the "
                     f"model's form); {r['n_missed_truth_unfitted']} with no fit of it (nothing it could rank, "
                     f"or the fit failed); top-1 where the logs prefer the truth "
                     f"{_pct(r['top1_truth_preferred'])}")
    for title, part in (("kind", r["by_kind"]), ("effect", r["by_effect"])):
        for k, v in part.items():
            lines.append(f"  {title} {k}: n {v['n']}, top-1 {_pct(v['top1'])}, recall {_pct(v['recall'])}, "
                         f"median shrink {_pct(v['median_shrink'])}; above their noise {v['n_detectable']}, "
                         f"top-1 {_pct(v['top1_detectable'])}"
                         + (f"; misses the truth fits better {v['n_missed_truth_better']}, not better "
                            f"{v['n_missed_truth_no_better']}" if "n_missed_truth_better" in v else ""))
    lines.append("confusion (true set -> top explanation: count):")
    for truth, row in sorted(r["confusion"].items()):
        lines.append(f"  {truth} -> " + ", ".join(f"{k}: {v}" for k, v in sorted(row.items())))
    return "\n".join(lines) + "\n"


def write(r: dict, out_dir: Path) -> dict:
    """proving-<family>.json and .txt under `out_dir`; their paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    js, tx = out_dir / f"proving-{r['family']}.json", out_dir / f"proving-{r['family']}.txt"
    js.write_text(json.dumps(r, indent=1, default=float))
    tx.write_text(text(r))
    return {"json": js, "text": tx}
