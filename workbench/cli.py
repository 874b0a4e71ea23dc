"""The `workbench` command line."""
from __future__ import annotations

import sys
from pathlib import Path

import click

from workbench.cli_logs import logs
from workbench.errors import InputError


@click.group()
@click.version_option(package_name="workbench")
def cli() -> None:
    """Hose-and-drogue aerial refueling simulation and validation workbench."""


cli.add_command(logs)


@cli.command()
@click.argument("case_file", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("reports/out"),
              show_default=True, help="Folder for the run's outputs.")
@click.option("--duration", type=float, default=None, help="Simulated seconds (default: the case's).")
def run(case_file: Path, out_dir: Path, duration: float | None) -> None:
    """Simulate one case: static trail, then the run; write time series, summary and plot."""
    from workbench.cases import load_case
    from workbench.run import run_case, write_outputs
    try:
        case = load_case(case_file)
        outcome = run_case(case, duration)
        paths = write_outputs(outcome, out_dir)
    except InputError as exc:
        raise click.ClickException(str(exc)) from None
    s = outcome.summary()
    click.echo(f"{case.id}: {s['simulated_s']:.2f} s simulated in {s['wall_s']:.3f} s "
               f"({s['realtime_factor']:.0f}x real time, step {s['step_ms']:.3f} ms)")
    click.echo(f"  static trail ({s['static_solve_ms']:.1f} ms): end at x={s['end_static_x_m']:.2f} "
               f"z={s['end_static_z_m']:.2f} m, tow tension {s['tow_tension_static_N']:.0f} N")
    click.echo(f"  end vertical range {s['end_z_range_m']:.3f} m, peak tow tension {s['tow_tension_max_N']:.0f} N")
    for p in paths:
        click.echo(f"  wrote {p}")


def main() -> None:
    cli.main(prog_name="workbench", standalone_mode=True)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
