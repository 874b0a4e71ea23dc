"""`workbench logs ...` verbs (owned by the flight-log ingest work)."""
from __future__ import annotations

import json
from pathlib import Path

import click
import numpy as np

from flighttest import FlightRecord, LogError, read_record


def _read(path: str, salvage: bool) -> FlightRecord:
    try:
        return read_record(path, salvage=salvage)
    except LogError as err:
        raise click.ClickException(str(err)) from None


def _gaps(t: np.ndarray) -> tuple[int, float]:
    """Intervals longer than 1.5 nominal periods, and the longest interval (s)."""
    if len(t) < 3:
        return 0, float("nan")
    dt = np.diff(t)
    return int(np.sum(dt > 1.5 * np.median(dt))), float(dt.max())


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) index pairs of runs of True."""
    padded = np.concatenate([[False], flags, [False]]).astype(int)
    edges = np.flatnonzero(np.diff(padded))
    return list(zip(edges[::2], edges[1::2]))


def _topic_stats(topic: str, df) -> dict:
    """Messages, rate, span, gaps and dropouts of one topic (None where they do not apply)."""
    if topic == "/video/hose":
        t = np.unique(df["t_s"].to_numpy(float))
        counts = df.groupby("t_s").size()
    else:
        t = df.index.to_numpy(float)
    n = len(t)
    out: dict = {"messages": n}
    if n == 0:
        return out
    dur = float(t[-1] - t[0]) if n > 1 else 0.0
    out.update(rate_hz=(n - 1) / dur if dur > 0 else None, duration_s=dur, t_first_s=float(t[0]),
               t_last_s=float(t[-1]))
    if topic != "/probe/events":
        n_gaps, longest = _gaps(t)
        out.update(gaps=n_gaps, longest_gap_s=longest if n_gaps else None)
    if "valid" in df:
        bad = ~df["valid"].to_numpy(bool)
        runs = _runs(bad)
        dt = float(np.median(np.diff(t))) if n > 1 else 0.0
        # A lost track lasts as many sample periods as it has invalid samples.
        out["dropouts"] = {"samples": int(bad.sum()), "share": float(bad.mean()), "runs": len(runs),
                           "longest_s": max(b - a for a, b in runs) * dt if runs else 0.0}
    if topic == "/probe/events":
        out["events"] = [{"t_s": float(t_), "event": str(e)} for t_, e in zip(df.index, df["event"])]
    if topic == "/video/hose":
        out["points_per_frame"] = [int(counts.min()), int(counts.max())]
    return out


def _topic_line(topic: str, st: dict) -> str:
    n = st["messages"]
    if n == 0:
        return f"  {topic:<20} {0:>7} msgs  (empty)"
    rate = st["rate_hz"]
    parts = [f"  {topic:<20} {n:>7} msgs", f"{rate:8.2f} Hz" if rate is not None else f"{'-':>8}   ",
             f"{st['duration_s']:8.3f} s", f"t {st['t_first_s']:.3f}-{st['t_last_s']:.3f} s"]
    if "gaps" in st:
        parts.append(f"gaps {st['gaps']}" + (f" (longest {st['longest_gap_s']:.3f} s)" if st["gaps"] else ""))
    if "dropouts" in st:
        d = st["dropouts"]
        parts.append(f"dropouts {d['samples']} ({100 * d['share']:.1f} %) in {d['runs']} runs, longest "
                     f"{d['longest_s']:.3f} s" if d["runs"] else "dropouts 0")
    if "events" in st:
        parts.append(", ".join(f"{e['event']} at {e['t_s']:.3f} s" for e in st["events"]))
    if "points_per_frame" in st:
        parts.append("points/frame {}-{}".format(*st["points_per_frame"]))
    return "  ".join(parts)


def inspect_json(path: str, record: FlightRecord) -> dict:
    """What `inspect_text` prints, as data: test card, topics' statistics, notes."""
    info = record.info
    return {"test_id": info.test_id, "test_kind": info.test_kind, "hose": info.hose,
            "summary": record.had_summary, "metadata": dict(info.raw),
            "topics": {topic: _topic_stats(topic, record.topics[topic]) for topic in sorted(record.topics)},
            "notes": list(record.warnings)}


def inspect_text(path: str, record: FlightRecord) -> str:
    info = record.info
    lines = [f"{Path(path).name}: test {info.test_id}  kind {info.test_kind}  hose {info.hose}"
             f"  summary {'yes' if record.had_summary else 'no (data section scanned)'}"]
    lines.append("  metadata:")
    for key, value in info.raw.items():
        lines.append(f"    {key} = {value}")
    lines.append("  topics:")
    for topic in sorted(record.topics):
        lines.append("  " + _topic_line(topic, _topic_stats(topic, record.topics[topic])))
    for w in record.warnings:
        lines.append(f"  note: {w}")
    return "\n".join(lines)


def _log_files(command):
    """FILES, --json and --salvage: what every `logs` verb takes."""
    for option in reversed((
            click.argument("files", nargs=-1, required=True, type=click.Path(dir_okay=False)),
            click.option("--json", "as_json", is_flag=True, help="One JSON object per file, keyed by the file name."),
            click.option("--salvage", is_flag=True, help="Read the complete records of a file cut inside a record."))):
        command = option(command)
    return command


@click.group()
def logs() -> None:
    """Inspect and analyze flight and bench logs."""


@logs.command("inspect")
@_log_files
def inspect_cmd(files: tuple[str, ...], as_json: bool, salvage: bool) -> None:
    """Summarise test card, topics, rates, gaps and dropouts of each FILE."""
    for i, path in enumerate(files):
        record = _read(path, salvage)
        if as_json:
            click.echo(json.dumps({Path(path).name: inspect_json(path, record)}, allow_nan=False))
            continue
        if i:
            click.echo("")
        click.echo(inspect_text(path, record))


def _fmt(value) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


@logs.command("analyze")
@_log_files
def analyze_cmd(files: tuple[str, ...], as_json: bool, salvage: bool) -> None:
    """Measure each FILE on its own (frequencies, damping, steady positions, ...)."""
    from flighttest.analyze import analyze_record

    for i, path in enumerate(files):
        record = _read(path, salvage)
        try:
            result = analyze_record(record)
        except LogError as err:
            raise click.ClickException(str(err)) from None
        if as_json:
            click.echo(json.dumps({Path(path).name: result}, allow_nan=False))
            continue
        if i:
            click.echo("")
        click.echo(f"{Path(path).name}:")
        for key, value in result.items():
            if key == "hose_shape":
                xs, zs = value["x_m"], value["z_m"]
                click.echo(f"  hose_shape: {len(xs)} bins of {value['bin_m']} m, "
                           f"x {xs[0]:.2f}..{xs[-1]:.2f} m, z {zs[0]:.3f}..{zs[-1]:.3f} m")
            elif isinstance(value, list):
                click.echo(f"  {key} = [{', '.join(_fmt(v) for v in value)}]")
            else:
                click.echo(f"  {key} = {_fmt(value)}")
