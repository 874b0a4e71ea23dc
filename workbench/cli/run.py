"""`workbench run`: one case through the solver."""
from __future__ import annotations

from pathlib import Path

import click

from workbench.budget import MAX_DURATION_S
from workbench.cli.params import FiniteFloatRange
from workbench.outputs import claim, safe_name, writable_file
from workbench.case_run import DEFAULT_OUT


@click.command()
@click.argument("case_file", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--log", "log_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="A flight log of the case's kind and hardware to run against (condition, tow point, "
                   "reel and probe from it); needed by cases that take them from a log.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=DEFAULT_OUT,
              show_default=True, help="Folder for the run's outputs (a subfolder per case id).")
@click.option("--duration", type=FiniteFloatRange(0.0, MAX_DURATION_S, min_open=True), default=None,
              help="Simulated seconds (default: the case's, or the log's span).")
@click.option("--force", is_flag=True, help="Overwrite this case's results of an earlier run in --out.")
@click.option("--effect", "effects", multiple=True, metavar="NAME[:key=value,...]",
              help="Turn on an unmodelled effect, over the case's [effects.NAME] (repeatable).")
@click.option("--mcap", "mcap_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Also write the run as an MCAP for Foxglove: the log contract's topics and a 3-D scene "
                   "(hose, drogue, tow point, tow and probe force arrows).")
@click.option("--animate", "gif_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Also write a GIF of the hose (side and top views; with --log over the video points).")
def run(case_file: Path, log_file: Path | None, out_dir: Path, duration: float | None, effects: tuple[str, ...],
        mcap_file: Path | None, gif_file: Path | None, force: bool) -> None:
    """Simulate one case: static trail, then the run; write time series, summary and plot."""
    from flighttest import read_record
    from workbench.cases import load_case
    from workbench.effects_case import parse_effect_options, with_effects
    from workbench.case_run import run_case, write_mcap, write_outputs
    case = with_effects(load_case(case_file), parse_effect_options(effects))
    record = read_record(log_file) if log_file is not None else None
    # the folder checked, unclaimed by another run and locked before any computing
    click.get_current_context().with_resource(claim(out_dir, [safe_name(case.id)], force))
    writable_file(mcap_file, "--mcap")
    writable_file(gif_file, "--animate")
    outcome = run_case(case, duration, record)
    paths = write_outputs(outcome, out_dir)
    if mcap_file is not None:
        paths.append(write_mcap(outcome, mcap_file))
    if gif_file is not None:
        from workbench.animate import animate
        paths.append(animate(outcome.result, gif_file, record=record, title=case.id))
    s = outcome.summary()
    against = f" against {s['log']}" if s["log"] else ""
    click.echo(f"{case.id}{against}: {s['simulated_s']:.2f} s simulated in {s['wall_s']:.3f} s "
               f"({s['realtime_factor']:.0f}x real time, step {s['step_ms']:.3f} ms)")
    solve = f" ({s['static_solve_ms']:.1f} ms)" if s["static_solve_ms"] is not None else ""
    click.echo(f"  static trail{solve}: end at x={s['end_static_x_m']:.2f} "
               f"z={s['end_static_z_m']:.2f} m, tow tension {s['tow_tension_static_N']:.0f} N")
    click.echo(f"  end vertical range {s['end_z_range_m']:.3f} m, peak tow tension {s['tow_tension_max_N']:.0f} N")
    for name, vals in case.tables.get("effects", {}).items():
        click.echo(f"  effect {name}: " + ", ".join(f"{k}={v:g}" for k, v in vals.items()))
    for p in paths:
        click.echo(f"  wrote {p}")
