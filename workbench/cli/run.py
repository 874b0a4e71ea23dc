"""`workbench run`: one case through the solver."""
from __future__ import annotations

from pathlib import Path

import click

from workbench.budget import MAX_DURATION_S
from workbench.cli.options import FiniteRange
from workbench.outputs import claim, safe_name


@click.command()
@click.argument("case_file", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("reports/out"),
              show_default=True, help="Folder for the run's outputs.")
@click.option("--duration", type=FiniteRange(0.0, MAX_DURATION_S, "s", lo_open=True), default=None,
              help="Simulated seconds (default: the case's).")
@click.option("--force", is_flag=True, help="Overwrite this case's results of an earlier run in --out.")
@click.option("--effect", "effects", multiple=True, metavar="NAME[:key=value,...]",
              help="Turn on an unmodelled effect, over the case's [effects.NAME] (repeatable).")
def run(case_file: Path, out_dir: Path, duration: float | None, effects: tuple[str, ...], force: bool) -> None:
    """Simulate one case: static trail, then the run; write time series, summary and plot."""
    from workbench.cases import load_case
    from workbench.effects_case import parse_effect_options, with_effects
    from workbench.run import run_case, write_outputs
    case = with_effects(load_case(case_file), parse_effect_options(effects))
    # the folder checked, unclaimed by another run and locked before any computing
    click.get_current_context().with_resource(claim(out_dir, [safe_name(case.id)], force))
    outcome = run_case(case, duration)
    paths = write_outputs(outcome, out_dir)
    s = outcome.summary()
    click.echo(f"{case.id}: {s['simulated_s']:.2f} s simulated in {s['wall_s']:.3f} s "
               f"({s['realtime_factor']:.0f}x real time, step {s['step_ms']:.3f} ms)")
    click.echo(f"  static trail ({s['static_solve_ms']:.1f} ms): end at x={s['end_static_x_m']:.2f} "
               f"z={s['end_static_z_m']:.2f} m, tow tension {s['tow_tension_static_N']:.0f} N")
    click.echo(f"  end vertical range {s['end_z_range_m']:.3f} m, peak tow tension {s['tow_tension_max_N']:.0f} N")
    for name, vals in case.tables.get("effects", {}).items():
        click.echo(f"  effect {name}: " + ", ".join(f"{k}={v:g}" for k, v in vals.items()))
    for p in paths:
        click.echo(f"  wrote {p}")
