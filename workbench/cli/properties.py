"""`workbench properties ...` verbs: hose property tables from the bench records."""
from __future__ import annotations

import sys
import time
from pathlib import Path

import click

from workbench.cli.params import FiniteFloatRange
from workbench.errors import EXIT_GATE_FAILED, InputError


@click.group()
def properties() -> None:
    """Hose element stiffness and damping from the bench ring-down records."""


@properties.command()
@click.option("--logs", "logs_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Folder of ring-down records (*.mcap) [default: flighttest/logs/ringdown].")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Folder to write hose_properties.json in; refused if one is there already "
                   "[default: a new folder under reports/out/properties].")
@click.option("--update-committed", is_flag=True,
              help="Overwrite the committed table cases/properties/hose_properties.json instead.")
@click.option("--hardware", "hardware_file", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="Data sheets [default: flighttest/logs/hardware.toml].")
@click.option("--element-counts", default=None,
              help="Comma-separated element counts to tune [default: 4,6,8,12,16,24,32,48,64]; "
                   "must include the verification's 8.")
@click.option("--quiet", is_flag=True, help="Only the summary, not every step.")
def build(logs_dir: Path | None, out_dir: Path | None, update_committed: bool, hardware_file: Path | None,
          element_counts: str | None, quiet: bool) -> None:
    """Measure the ring-downs, tune the element constants, verify, write the tables.

    The committed table is only overwritten with --update-committed: a build
    writes under --out otherwise."""
    from flighttest import LogError
    from workbench.hardware import load_hardware
    from workbench.properties.build import DEFAULT_LOGS, ELEMENT_COUNTS, build_properties
    from workbench.properties.store import build_target, write_properties

    t0 = time.perf_counter()
    counts = ELEMENT_COUNTS
    if element_counts is not None:
        try:
            counts = tuple(int(x) for x in element_counts.split(",") if x.strip())
        except ValueError:
            raise click.BadParameter(f"{element_counts!r} is not a comma-separated list of integers",
                                     param_hint="--element-counts") from None
        if not counts or not all(2 <= n <= 256 for n in counts):
            raise click.BadParameter(f"{element_counts!r}: each count must lie in 2..256 (a bench section "
                                     f"of 1-2 m in elements of 5 mm or more)", param_hint="--element-counts")
    try:
        target = build_target(out_dir, update_committed)
    except InputError as exc:
        raise click.BadParameter(str(exc), param_hint="--out") from None

    def progress(msg: str) -> None:
        if not quiet:
            click.echo(f"[{time.perf_counter() - t0:6.1f} s] {msg}")

    try:
        hw = load_hardware(hardware_file)
        doc = build_properties(logs_dir if logs_dir is not None else DEFAULT_LOGS, hw,
                               element_counts=counts, progress=progress)
        path = write_properties(doc, target)
    except InputError as exc:
        raise click.ClickException(str(exc)) from None
    except LogError as exc:
        raise click.ClickException(str(exc)) from None
    except RuntimeError as exc:   # a tuning or equilibrium that did not converge
        raise click.ClickException(f"property build failed: {exc}") from None
    wall = time.perf_counter() - t0
    for hose, prov in doc["hoses"].items():
        if prov["status"] == "derived":
            click.echo(f"{hose}: DERIVED from {prov['derived_from']} x {prov['scale_factor']:.4f} "
                       f"(second moment of area ratio; never bench tested)")
            continue
        t = doc["tables"][hose]
        click.echo(f"{hose}: {len(t['temperatures_F'])} temperatures "
                   f"{t['temperatures_F'][0]:.1f}..{t['temperatures_F'][-1]:.1f} F, "
                   f"{len(t['element_lengths_m'])} element lengths "
                   f"{t['element_lengths_m'][0]:.4f}..{t['element_lengths_m'][-1]:.4f} m; axial at "
                   f"{prov['room_temperature_F']:.1f} F scaled like bending (assumption)")
    rows = doc["verification"]
    bad = [r for r in rows if not r["within_tolerance"]]
    worst_f = max(abs(r["frequency_error_pct"]) for r in rows)
    worst_z = max(abs(r["damping_error_pct"]) for r in rows)
    tol = doc["verification_tolerance_pct"]
    click.echo(f"verification (N={rows[0]['n_elements']}, time simulation): {len(rows) - len(bad)}/{len(rows)} "
               f"within {tol['frequency']:g} % / {tol['damping']:g} %; worst frequency {worst_f:.3f} %, "
               f"worst damping {worst_z:.3f} %")
    click.echo(f"wrote {path} in {wall:.1f} s")
    if bad:   # the verification is a gate: exit 1, not the bad-input 2 a ClickException stands for
        click.echo(f"FAIL {len(bad)} verification case(s) outside tolerance: " + "; ".join(
            f"{r['hose']} {r['test']} {r['temperature_F']:.1f} F" for r in bad), err=True)
        sys.exit(EXIT_GATE_FAILED)


@properties.command()
@click.argument("hose")
@click.argument("temperature_f", type=FiniteFloatRange(-100.0, 350.0))   # the log contract's chamber range
@click.argument("element_length_m", type=FiniteFloatRange(0.0, 10.0, min_open=True))
@click.option("--file", "prop_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Property file [default: cases/properties/hose_properties.json].")
@click.option("--allow-extrapolation", is_flag=True,
              help="Extrapolate the temperature spline beyond the tested range.")
def lookup(hose: str, temperature_f: float, element_length_m: float, prop_file: Path | None,
           allow_extrapolation: bool) -> None:
    """Element constants of HOSE at TEMPERATURE_F (deg F) for ELEMENT_LENGTH_M (m)."""
    from workbench.properties.store import DEFAULT_PATH, load_library

    try:
        lib = load_library(prop_file if prop_file is not None else DEFAULT_PATH)
        ka, ca, kb, cb = lib.constants(hose, temperature_f, element_length_m, allow_extrapolation)
    except (InputError, ValueError) as exc:
        raise click.ClickException(str(exc)) from None
    note = lib.table(hose).note
    click.echo(f"{hose} at {temperature_f:g} F, element {element_length_m:g} m:")
    click.echo(f"  k_a = {ka:.6g} N/m      c_a = {ca:.6g} N s/m")
    click.echo(f"  k_b = {kb:.6g} N m/rad  c_b = {cb:.6g} N m s/rad")
    if note:
        click.echo(f"  ({note})")
