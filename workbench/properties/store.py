"""The property document on disk: written, read and loaded as a `PropertyLibrary`."""
from __future__ import annotations

import json
import tempfile
from datetime import datetime, timezone
from pathlib import Path

from solver.properties import PropertyLibrary
from workbench.errors import InputError
from workbench.provenance import ROOT, FileCache, json_safe, read_text_limited

# The committed table that cases with `source = "table"` use.
DEFAULT_PATH = ROOT / "cases" / "properties" / "hose_properties.json"
FORMAT = "hose-properties/1"
# Where `workbench properties build` writes unless told to update the committed
# table: beside the other generated reports (git-ignored), a new folder per
# build, so a trial build never replaces the committed numbers or another build.
DEFAULT_OUT = ROOT / "reports" / "out" / "properties"


def build_target(out_dir: str | Path | None, update_committed: bool = False) -> Path:
    """The file a build writes, checked writable before any computing: the
    committed table only on request; else hose_properties.json in `out_dir`
    (refused if one is there already), or in a new time-stamped folder under
    DEFAULT_OUT."""
    if update_committed:
        if out_dir is not None:
            raise InputError("--out and --update-committed: give one, not both")
        target = DEFAULT_PATH
    elif out_dir is None:
        stamp = datetime.now(timezone.utc).strftime("%Y%m%d-%H%M%S")
        target = DEFAULT_OUT / stamp / DEFAULT_PATH.name
        n = 1
        while target.parent.exists():
            n += 1
            target = DEFAULT_OUT / f"{stamp}-{n}" / DEFAULT_PATH.name
    else:
        target = Path(out_dir) / DEFAULT_PATH.name
        if target.exists():
            raise InputError(f"{target}: a property file is already there (another build's); "
                             f"choose another --out")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=target.parent):
            pass
    except OSError as exc:
        raise InputError(f"{target.parent}: cannot write there ({exc.strerror or exc})") from None
    return target


def write_properties(doc: dict, path: str | Path = DEFAULT_PATH) -> Path:
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    tmp = p.with_suffix(p.suffix + ".tmp")
    tmp.write_text(json.dumps(json_safe(doc), indent=1, allow_nan=False) + "\n", encoding="utf-8")
    tmp.replace(p)
    return p


def read_properties(path: str | Path = DEFAULT_PATH) -> dict:
    p = Path(path)
    if not p.exists():
        raise InputError(f"{p}: property file not found (make it with 'workbench properties build')")
    try:
        doc = json.loads(read_text_limited(p, "property file"))
    except json.JSONDecodeError as exc:
        raise InputError(f"{p}: not valid JSON ({exc})") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise InputError(f"{p}: format {doc.get('format') if isinstance(doc, dict) else None!r}, "
                         f"expected {FORMAT!r}")
    return doc


_libraries = FileCache()


def load_library(path: str | Path = DEFAULT_PATH) -> PropertyLibrary:
    """The property tables of the data file, by hose id. Read once per version of
    the file: case building calls this inside fit loops."""
    return _libraries.get(path, _read_library)


def _read_library(path: Path) -> PropertyLibrary:
    doc = read_properties(path)
    try:
        return PropertyLibrary.from_dict(doc["tables"])
    except (KeyError, ValueError, TypeError) as exc:
        raise InputError(f"{path}: bad property tables ({exc})") from None
