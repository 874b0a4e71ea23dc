"""`workbench diagnose`: the sim-to-real gap of flight logs, the effect that
explains it and how far it shrinks (`workbench.diagnosis`); `--selftest`
proves the method on generated logs whose effect it is not told."""
from __future__ import annotations

import json
from pathlib import Path

import click

from workbench.cli.params import WORKERS
from workbench.errors import InputError
from workbench.outputs import claim, timestamped
from workbench.proving import FAMILIES
from workbench.provenance import ROOT, project_path

# the diagnosis the repository keeps (validate folds it into its report): only
# --update-committed writes it
COMMITTED = ROOT / "reports" / "diagnose"


@click.command()
@click.argument("logs", nargs=-1, type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Folder for diagnosis.json and diagnosis.html [default: a new folder "
                   "reports/out/diagnose-<time>].")
@click.option("--update-committed", is_flag=True,
              help=f"Write the committed diagnosis ({COMMITTED.relative_to(ROOT)}) instead, over the old one.")
@click.option("--force", is_flag=True, help="Overwrite an earlier diagnosis in --out.")
@click.option("--selftest", is_flag=True, help="Generate logs with a withheld effect and diagnose them blind.")
@click.option("--n", "n_logs", type=click.IntRange(1, 1000), default=42, show_default=True,
              help="Generated logs in the selftest.")
@click.option("--seed", type=click.IntRange(0, 2 ** 32 - 1), default=2026, show_default=True,
              help="Selftest random seed.")
@click.option("--n-elements", type=click.IntRange(4, 200), default=None,
              help="Hose elements of the diagnosis (default 20).")
@click.option("--workers", type=WORKERS, default=None, help="Local worker processes (default: all cores).")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Run the candidate fits on a Dask distributed cluster (e.g. tcp://host:8786).")
@click.option("--no-progress", is_flag=True, help="No progress display (CI); the summary lines stay.")
@click.option("--quiet", is_flag=True, help="Only the final line and errors.")
@click.option("--proving-ground", "proving", type=click.Choice(["own", "independent"]), default="own",
              show_default=True, help="Selftest logs from the diagnosis's own model, or from the independent-form "
                                      "proving ground (workbench.proving).")
@click.option("--family", type=click.Choice(FAMILIES), default="single",
              show_default=True, help="Proving ground: one effect per log, 2-3 at once, one at a fraction of its "
                                      "size (near the noise), or none withheld (false alarms).")
@click.option("--baseline", type=click.Choice(["fleet", "datasheet"]), default="fleet", show_default=True,
              help="What LOGS are diagnosed against: their family's fleet calibration where cases/fleet/fleet.toml "
                   "lists it (what the program's flights established about the hardware), else the data "
                   "sheets; or the data sheets alone. --update-committed re-derives the fleet file from "
                   "the program's logs and needs datasheet.")
def diagnose(logs, out_dir, update_committed, force, selftest, n_logs, seed, n_elements, workers,
             scheduler, no_progress, quiet, proving, family, baseline) -> None:
    """Where the simulation departs from LOGS, which unmodelled effect explains it, how far the gap shrinks."""
    from workbench.progress import Progress
    # the display comes up first: the imports below take seconds
    progress = Progress("diagnose", enabled=not (no_progress or quiet))
    progress.doing("loading the model code")
    say = click.echo if not quiet else (lambda line: None)
    try:
        from workbench import diagnosis as D
        if not (logs or selftest):
            raise InputError("give one or more LOG.mcap files, or --selftest")
        if update_committed and logs and baseline != "datasheet":
            raise InputError("--update-committed: the committed diagnosis derives the fleet calibration "
                             f"({D.FLEET_PATH.relative_to(ROOT)}) from the data sheets; give --baseline datasheet")
        out_dir = _out_folder(out_dir, update_committed)
        # the folder checked, unclaimed by another run and locked before any computing
        click.get_current_context().with_resource(
            claim(out_dir, ["diagnosis.json", "selftest.json", *(f"proving-{f}.json" for f in FAMILIES)],
                  force or update_committed))
        if selftest and proving == "independent":
            _proving_ground(n_logs, family, seed, n_elements, workers, scheduler, out_dir, progress)
            return
        if selftest:
            from workbench.diagnosis.selftest import run_selftest
            progress.add(n_logs, "generating and diagnosing the logs")
            r = run_selftest(n=n_logs, seed=seed, n_elements=n_elements, workers=workers, scheduler=scheduler,
                             out_dir=out_dir, progress=progress.done)
            path = D.write_selftest(r, out_dir)
        else:
            # the diagnosis reports its stages as they end (baseline, screen,
            # fits): each is a step of the display, its total growing with them
            out = D.diagnose([str(p) for p in logs], n_elements or D.DEFAULT_ELEMENTS, workers, scheduler,
                             progress=lambda what: (progress.add(1), progress.done(what)), baseline=baseline)
            progress.add(1, "writing diagnosis.json and diagnosis.html")
            files = D.write_diagnosis(out, out_dir)
            if update_committed:
                files["fleet"] = D.write_fleet(out, " ".join(
                    ["workbench diagnose", *(project_path(p) for p in logs),
                     "--baseline datasheet --update-committed"]))
            progress.done()
    except BaseException:
        # the error's one line stands alone; the group's guard gives it its exit code
        # (bad input 2, a baseline that does not simulate 3)
        progress.close(keep=False)
        raise
    progress.close()
    if selftest:
        for k, v in r["by_kind"].items():
            say(f"  {k}: n {v['n']}, top-1 {100 * v['top1']:.0f} %, median shrink {100 * v['median_shrink']:.0f} %")
        click.echo(f"selftest: {r['n']} logs, top-1 {100 * r['top1']:.0f} %, held-out shrink median "
                   f"{100 * r['median_shrink']:.0f} % (>= 70 % in {100 * r['share_shrink_ge_70pct']:.0f} % of "
                   f"logs); {path}; total {progress.elapsed_s:.1f} s")
        return
    for name, d in out.families.items():
        top = d.ranking[0]
        say(f"{name}: gap {d.gap_before:.3f} m (floor {d.noise_floor:.3f}); best {top.effect} "
            f"{json.dumps(top.params, default=float)} -> held out {top.gap_after_heldout:.3f} m ({d.wall_s:.0f} s)")
    for name, d in out.families.items():
        if d.baseline:
            say(f"{name}: diagnosed against its fleet calibration ({D.FLEET_PATH.name}): "
                + ", ".join(f"{e} {json.dumps(ps)}" for e, ps in d.baseline.items()))
    click.echo(f"wrote {files['json']} and {files['html'].name}"
               + (f" and {files['fleet'].relative_to(ROOT)}" if "fleet" in files else "")
               + f"; total {progress.elapsed_s:.1f} s")


def _out_folder(out_dir: Path | None, update_committed: bool) -> Path:
    if update_committed:
        if out_dir is not None:
            raise InputError("--out and --update-committed: give one, not both")
        return COMMITTED
    if out_dir is not None and out_dir.resolve() == COMMITTED.resolve():
        # --force overwrites another run's results, never the committed ones
        raise InputError(f"--out {out_dir}: is the committed diagnosis; write it only with --update-committed")
    return out_dir if out_dir is not None else timestamped(ROOT / "reports" / "out", "diagnose")


def _proving_ground(n_logs, family, seed, n_elements, workers, scheduler, out_dir, progress) -> None:
    """The diagnosis scored on the independent-form proving ground; its
    figures as proving-<family>.json and .txt under `out_dir`."""
    from workbench.proving.campaign import run_campaign, text, write
    progress.add(n_logs, f"proving ground ({family}): generating and diagnosing the logs")
    r = run_campaign(n_logs, family, seed, n_elements, workers, scheduler, out_dir,
                     progress=lambda row: progress.done(f"{row.get('log', 'log')} diagnosed"))
    files = write(r, out_dir)
    progress.close()
    click.echo(text(r), nl=False)
    click.echo(f"wrote {files['json']} and {files['text']}")
