"""`workbench diagnose`: the sim-to-real gap of flight logs, the effect that
explains it and how far it shrinks (`workbench.diagnosis`); `--selftest`
proves the method on generated logs whose effect it is not told."""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import click

from workbench.errors import InputError


@click.command()
@click.argument("logs", nargs=-1, type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("reports/diagnose"),
              show_default=True, help="Folder for diagnosis.json and diagnosis.html.")
@click.option("--selftest", is_flag=True, help="Generate logs with a withheld effect and diagnose them blind.")
@click.option("--n", "n_logs", type=int, default=42, show_default=True, help="Generated logs in the selftest.")
@click.option("--seed", type=int, default=2026, show_default=True, help="Selftest random seed.")
@click.option("--n-elements", type=int, default=None, help="Hose elements of the diagnosis (default 20).")
@click.option("--workers", type=int, default=None, help="Local worker processes (default: all cores).")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Run the candidate fits on a Dask distributed cluster (e.g. tcp://host:8786).")
@click.option("--proving-ground", "proving", type=click.Choice(["own", "independent"]), default="own",
              show_default=True, help="Selftest logs from the diagnosis's own model, or from the independent-form "
                                      "proving ground (workbench.proving).")
@click.option("--family", type=click.Choice(["single", "multi"]), default="single", show_default=True,
              help="Proving ground: one effect per log, or 2-3 at once.")
@click.option("--update-committed", is_flag=True,
              help="Let the proving ground write its figures into the committed reports/diagnose/.")
def diagnose(logs, out_dir, selftest, n_logs, seed, n_elements, workers, scheduler, proving, family,
             update_committed) -> None:
    """Where the simulation departs from LOGS, which unmodelled effect explains it, how far the gap shrinks."""
    from workbench import diagnosis as D
    t0 = time.perf_counter()
    try:
        if selftest and proving == "independent":
            _proving_ground(n_logs, family, seed, n_elements, workers, scheduler, out_dir, update_committed)
            return
        if selftest:
            from workbench.diagnosis.selftest import run_selftest
            out_dir.mkdir(parents=True, exist_ok=True)
            r = run_selftest(n=n_logs, seed=seed, n_elements=n_elements, workers=workers, scheduler=scheduler,
                             out_dir=out_dir, progress=click.echo)
            path = D.write_selftest(r, out_dir)
            click.echo(f"selftest: {r['n']} logs, top-1 {100 * r['top1']:.0f} %, held-out shrink median "
                       f"{100 * r['median_shrink']:.0f} % (>= 70 % in {100 * r['share_shrink_ge_70pct']:.0f} % of "
                       f"logs), {r['wall_s']:.0f} s; {path}")
            for k, v in r["by_kind"].items():
                click.echo(f"  {k}: n {v['n']}, top-1 {100 * v['top1']:.0f} %, median shrink "
                           f"{100 * v['median_shrink']:.0f} %")
            return
        if not logs:
            raise InputError("give one or more LOG.mcap files, or --selftest")
        out = D.diagnose([str(p) for p in logs], n_elements or D.DEFAULT_ELEMENTS, workers, scheduler,
                         progress=click.echo)
    except InputError as exc:
        click.echo(f"error: {exc}", err=True)
        sys.exit(2)
    except D.SimulationFailed as exc:
        # the baseline itself does not simulate: nothing to diagnose against
        click.echo(f"error: baseline simulation failed: {exc}", err=True)
        sys.exit(3)
    files = D.write_diagnosis(out, out_dir)
    for name, d in out.families.items():
        top = d.ranking[0]
        click.echo(f"{name}: gap {d.gap_before:.3f} m (floor {d.noise_floor:.3f}); best {top.effect} "
                   f"{json.dumps(top.params, default=float)} -> held out {top.gap_after_heldout:.3f} m "
                   f"({d.wall_s:.0f} s)")
    click.echo(f"wrote {files['json']} ({time.perf_counter() - t0:.0f} s)")


COMMITTED = Path(__file__).resolve().parents[2] / "reports" / "diagnose"


def _proving_ground(n_logs, family, seed, n_elements, workers, scheduler, out_dir, update_committed) -> None:
    """The diagnosis scored on the independent-form proving ground; its
    figures as proving-<family>.json and .txt under `out_dir`."""
    if out_dir.resolve() == COMMITTED.resolve() and not update_committed:
        raise InputError(f"--out {out_dir}: the proving ground does not write into the committed reports/diagnose/ "
                         f"unless --update-committed; give another --out")
    from workbench.proving.campaign import run_campaign, text, write
    r = run_campaign(n_logs, family, seed, n_elements, workers, scheduler, out_dir)
    files = write(r, out_dir)
    click.echo(text(r), nl=False)
    click.echo(f"wrote {files['json']} and {files['text']}")
