"""`workbench compare`: a flight log and its simulation, on one time base, for Foxglove."""
from __future__ import annotations

from pathlib import Path

import click

from workbench.budget import MAX_DURATION_S
from workbench.cli.params import FiniteFloatRange
from workbench.outputs import writable_file


@click.command()
@click.argument("log_file", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--mcap", "mcap_file", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="The MCAP to write: the log's topics under /log, the simulation's under /sim, each with "
                   "its Foxglove 3-D scene.")
@click.option("--case", "case_file", default=None, metavar="CASE",
              help="The case to simulate (a file, or a name under cases/); default: the case in cases/ that "
                   "lists the log, else the diagnosis's baseline template for the log's kind.")
@click.option("--duration", type=FiniteFloatRange(0.0, MAX_DURATION_S, min_open=True), default=None,
              help="Simulated seconds from the log's start (default: the case's, or the log's span).")
@click.option("--animate", "gif_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Also write a GIF of the simulated hose over the log's video points.")
def compare(log_file: Path, mcap_file: Path, case_file: str | None, duration: float | None,
            gif_file: Path | None) -> None:
    """Simulate LOG's case against LOG and write both into one MCAP that scrubs together in Foxglove."""
    from flighttest import read_record
    from workbench.cases import load_case
    from workbench.cli.validate import case_paths
    from workbench.case_run import case_for_log, run_case, write_comparison_mcap
    record = read_record(log_file)
    case = load_case(case_paths((case_file,))[0]) if case_file else case_for_log(record)
    writable_file(mcap_file, "--mcap")      # before any computing
    writable_file(gif_file, "--animate")
    outcome = run_case(case, duration, record)
    paths = [write_comparison_mcap(outcome, mcap_file)]
    if gif_file is not None:
        from workbench.animate import animate
        paths.append(animate(outcome.result, gif_file, record=record, title=f"{case.id} on {record.info.test_id}"))
    s = outcome.summary()
    click.echo(f"{record.info.test_id}: case {case.id}, {s['simulated_s']:.2f} s simulated in {s['wall_s']:.1f} s")
    for p in paths:
        click.echo(f"  wrote {p}")
