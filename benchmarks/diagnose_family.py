"""Diagnosis speed: one log family against issue 13's 5 minutes on the 2-core machine.

    python3 benchmarks/diagnose_family.py [--family PD TR EN] [--workers 2] [--baseline datasheet] [--json]

Diagnoses each of the program's flight families (flighttest/logs/flight: the
G-III doublets PD-*, the KDC-10 trails TR-*, the engagements EN-*) on its own,
as `workbench diagnose` would, and prints each family's wall time with the set
it selected and its held-out gap, so a speed change is seen beside what it did
to the answer. Against the data sheets by default: the baseline the fleet
calibration is derived from, and the longest search (the fleet baseline starts
nearer). Run it on an otherwise idle machine; times move with other load.
"""
from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

from workbench.diagnosis.rank import BASELINES, diagnose

FLIGHT = Path(__file__).resolve().parent.parent / "flighttest" / "logs" / "flight"
TARGET_S = 300.0     # issue 13, item 7: one log family <= 5 min on this 2-core machine


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--family", nargs="+", default=["PD", "TR", "EN"], help="log name prefixes, one family each")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--baseline", choices=BASELINES, default="datasheet")
    ap.add_argument("--json", action="store_true", help="one JSON object instead of the table")
    args = ap.parse_args()
    rows = []
    for prefix in args.family:
        paths = sorted(str(p) for p in FLIGHT.glob(f"{prefix}-*.mcap"))
        t = time.perf_counter()
        d = diagnose(paths, workers=args.workers, baseline=args.baseline)
        wall = time.perf_counter() - t
        for name, fam in d.families.items():
            top = fam.ranking[0]
            rows.append({"family": name, "logs": len(paths), "wall_s": wall, "within_target": wall <= TARGET_S,
                         "selected": top.effect, "gap_before_m": fam.gap_before,
                         "gap_heldout_m": top.gap_after_heldout})
    if args.json:
        print(json.dumps({"machine": platform.processor() or platform.machine(), "workers": args.workers,
                          "baseline": args.baseline, "target_s": TARGET_S, "families": rows}, indent=1))
        return
    print(f"diagnosis per family, {args.workers} workers, against the {args.baseline} baseline "
          f"(target {TARGET_S:.0f} s a family)")
    for r in rows:
        print(f"  {r['family']:<32} {r['logs']} logs  {r['wall_s']:6.0f} s  {'ok  ' if r['within_target'] else 'OVER'}"
              f"  {r['selected']}: {r['gap_before_m']:.3f} -> {r['gap_heldout_m']:.3f} m held out")


if __name__ == "__main__":
    main()
