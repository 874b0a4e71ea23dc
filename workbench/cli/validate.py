"""`workbench validate`: cases against their logs, gates and findings, the report."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import click

from workbench.cli.params import WORKERS
from workbench.errors import EXIT_GATE_FAILED, InputError
from workbench.outputs import claim
from workbench.provenance import read_text_limited

CASES = Path(__file__).resolve().parents[2] / "cases"
# what a validate run leaves in --out: a folder holding one is another run's
RESULTS = ("results.json", "report.html", "junit.xml")


def case_paths(targets: tuple[str, ...]) -> list[Path]:
    """`all` (every cases/*.toml), or case files, or case names under cases/."""
    if list(targets) == ["all"]:
        return sorted(CASES.glob("*.toml"))
    paths = []
    for t in targets:
        p = Path(t)
        if not p.exists() and (CASES / f"{t}.toml").exists():
            p = CASES / f"{t}.toml"
        if not p.is_file():
            also = "" if p.suffix == ".toml" or len(p.parts) > 1 else f" (nor cases/{t}.toml)"
            raise InputError(f"{t}: no such case file{also}")
        paths.append(p)
    return paths


def _diagnosis_section(diagnosis_file: Path) -> list:
    from workbench.diagnosis.report import report_blocks
    try:
        diag = json.loads(read_text_limited(diagnosis_file, "diagnosis file"))
        # the blind selftest's figures, when `diagnose --selftest` wrote them beside it
        st = diagnosis_file.with_name("selftest.json")
        if st.exists():
            diag["selftest"] = json.loads(read_text_limited(st, "selftest file"))
        return report_blocks(diag)
    except (ValueError, KeyError, TypeError, AttributeError) as exc:   # any JSON that is not one
        raise InputError(f"{diagnosis_file}: not a diagnosis.json ({type(exc).__name__}: {exc})") from None


@click.command()
@click.argument("targets", nargs=-1, required=True)
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("reports/out"),
              show_default=True, help="Folder for report.html, report.pdf, results.json, junit.xml.")
@click.option("--workers", type=WORKERS, default=None, help="Processes (default: one per core).")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Run the campaign on a Dask distributed cluster (e.g. tcp://host:8786) instead of local processes.")
@click.option("--force", is_flag=True, help="Overwrite the results of an earlier run in --out.")
@click.option("--no-progress", is_flag=True, help="No progress display (CI); the summary lines stay.")
@click.option("--quiet", is_flag=True, help="Only the final line and errors.")
@click.option("--diagnosis", "diagnosis_file", type=click.Path(dir_okay=False, path_type=Path),
              default=Path("reports/diagnose/diagnosis.json"), show_default=True,
              help="A diagnosis.json to fold into the report as its own section (skipped if absent).")
def validate(targets: tuple[str, ...], out_dir: Path, workers: int | None, scheduler: str | None,
             no_progress: bool, quiet: bool, diagnosis_file: Path, force: bool) -> None:
    """Run cases against their logs, check gates and findings: `validate all` or `validate CASE...`.

    Exit status: 0 every gate passes and every finding is as expected; 1 a gate
    fails or a finding changed; 2 a case is bad input; 3 a case's simulation
    failed numerically (the highest applies)."""
    from workbench.progress import Progress
    # the display comes up first: the imports and case loading below take seconds
    progress = Progress("validate", enabled=not (no_progress or quiet))
    progress.doing("loading the model code")
    try:
        from workbench.report import finding_message, gate_message, report_steps, write_report
        from workbench.validation import results_dict, validate_cases
        paths = case_paths(targets)
        # the folder checked, unclaimed by another run and locked before any computing
        click.get_current_context().with_resource(claim(out_dir, RESULTS, force))
        # a bad --diagnosis is refused before the runs, not after them
        sections = [_diagnosis_section(diagnosis_file)] if diagnosis_file.exists() else []
        outcomes = validate_cases(paths, workers=workers, progress=progress, scheduler=scheduler)
        results = results_dict(outcomes)
        wall = progress.elapsed_s
        results["wall_s"] = wall
        progress.add(report_steps(len(outcomes)), "writing the report")
        files = write_report(outcomes, results, out_dir, wall, extra_sections=sections,
                             step=lambda what: progress.done(f"wrote {what}"))
    except BaseException:
        progress.close(keep=False)   # the error's one line stands alone
        raise
    progress.close()
    cases = results["cases"]
    gates = [g for c in cases for g in c["gates"]]
    findings = [f for c in cases for f in c["findings"]]
    for c in cases:
        if c["error"]:
            click.echo(f"ERROR {c['id']}: did not run: {c['error']}", err=True)
        for g in c["gates"]:
            if not g["passed"]:
                click.echo(f"FAIL {gate_message(c['id'], g)}", err=True)
        for f in c["findings"]:
            if not f["passed"]:
                click.echo(f"CHANGED {finding_message(c['id'], f)}", err=True)
    click.echo(f"{len(outcomes)} cases, {sum(g['passed'] for g in gates)}/{len(gates)} gates pass, "
               f"{sum(f['passed'] for f in findings)}/{len(findings)} findings as expected; report {files['html']}; "
               f"total {progress.elapsed_s:.1f} s (runs {wall:.1f} s, report {progress.elapsed_s - wall:.1f} s)")
    codes = [c["error_code"] for c in cases if c["error"]]
    if codes:
        sys.exit(max(codes))
    if not results["passed"]:
        sys.exit(EXIT_GATE_FAILED)
