"""The `workbench` command line."""
from __future__ import annotations

import sys
from pathlib import Path

import click

from workbench.cli_diagnose import diagnose
from workbench.cli_logs import logs
from workbench.cli_properties import properties
from workbench.errors import InputError


@click.group()
@click.version_option(package_name="workbench")
def cli() -> None:
    """Hose-and-drogue aerial refueling simulation and validation workbench."""


cli.add_command(logs)
cli.add_command(properties)
cli.add_command(diagnose)


@cli.command()
@click.argument("case_file", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("reports/out"),
              show_default=True, help="Folder for the run's outputs.")
@click.option("--duration", type=float, default=None, help="Simulated seconds (default: the case's).")
@click.option("--effect", "effects", multiple=True, metavar="NAME[:key=value,...]",
              help="Turn on an unmodelled effect, over the case's [effects.NAME] (repeatable).")
def run(case_file: Path, out_dir: Path, duration: float | None, effects: tuple[str, ...]) -> None:
    """Simulate one case: static trail, then the run; write time series, summary and plot."""
    from workbench.cases import load_case
    from workbench.effects_case import parse_effect_options, with_effects
    from workbench.run import run_case, write_outputs
    try:
        case = with_effects(load_case(case_file), parse_effect_options(effects))
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
    for name, vals in case.tables.get("effects", {}).items():
        click.echo(f"  effect {name}: " + ", ".join(f"{k}={v:g}" for k, v in vals.items()))
    for p in paths:
        click.echo(f"  wrote {p}")


@cli.command()
@click.argument("targets", nargs=-1, required=True)
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("reports/out"),
              show_default=True, help="Folder for report.html, report.pdf, results.json, junit.xml.")
@click.option("--workers", type=int, default=None, help="Processes (default: one per core).")
@click.option("--no-progress", is_flag=True, help="No progress bar.")
@click.option("--diagnosis", "diagnosis_file", type=click.Path(dir_okay=False, path_type=Path),
              default=Path("reports/diagnose/diagnosis.json"), show_default=True,
              help="A diagnosis.json to fold into the report as its own section (skipped if absent).")
def validate(targets: tuple[str, ...], out_dir: Path, workers: int | None, no_progress: bool,
             diagnosis_file: Path) -> None:
    """Run cases against their logs and gate them: `validate all` or `validate CASE...`.

    Exit status: 0 all gates pass, 1 a gate fails (a finding about the model),
    2 a case could not run (a defect or bad input)."""
    import time
    from workbench.report import gate_message, write_report
    from workbench.validate import results_dict, validate_cases
    root = Path(__file__).resolve().parent.parent / "cases"
    if list(targets) == ["all"]:
        paths = sorted(root.glob("*.toml"))
    else:
        paths = []
        for t in targets:
            p = Path(t)
            if not p.exists() and (root / f"{t}.toml").exists():
                p = root / f"{t}.toml"
            if not p.exists():
                raise click.ClickException(f"{t}: no such case file (nor cases/{t}.toml)")
            paths.append(p)
    t0 = time.perf_counter()
    try:
        outcomes = validate_cases(paths, workers=workers, progress=not no_progress)
    except InputError as exc:
        raise click.ClickException(str(exc)) from None
    results = results_dict(outcomes)
    wall = time.perf_counter() - t0
    results["wall_s"] = wall
    sections = []
    if diagnosis_file.exists():
        import json
        from workbench.diagnosis.report import report_section
        try:
            diag = json.loads(diagnosis_file.read_text())
            # the blind selftest's figures, when `diagnose --selftest` wrote them beside it
            st = diagnosis_file.with_name("selftest.json")
            if st.exists():
                diag["selftest"] = json.loads(st.read_text())
            sections.append(report_section(diag))
        except (ValueError, KeyError) as exc:
            raise click.ClickException(f"{diagnosis_file}: not a diagnosis.json ({exc})") from None
    files = write_report(outcomes, results, out_dir, wall, extra_sections=sections)
    n_g = sum(len(c["gates"]) for c in results["cases"])
    n_ok = sum(g["passed"] for c in results["cases"] for g in c["gates"])
    click.echo(f"{len(outcomes)} cases, {n_ok}/{n_g} gates pass, {wall:.1f} s; report {files['html']}")
    errors = [f"{c['id']}: did not run: {c['error']}" for c in results["cases"] if c["error"]]
    failures = [gate_message(c["id"], g) for c in results["cases"] for g in c["gates"] if not g["passed"]]
    for f in errors:
        click.echo(f"ERROR {f}", err=True)
    for f in failures:
        click.echo(f"FAIL {f}", err=True)
    if errors:
        sys.exit(2)
    if failures:
        sys.exit(1)


def main() -> None:
    cli.main(prog_name="workbench", standalone_mode=True)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
