"""Where a stored result came from, and how it is stored: the code version, file
hashes, dependency versions, one JSON-safe converter, and a cache of parsed
input files that re-reads a file once it changes."""
from __future__ import annotations

import functools
import hashlib
import math
import subprocess
from importlib import metadata
from pathlib import Path
from types import ModuleType
from typing import Any, Callable, Iterable

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
DEPENDENCIES = ("numpy", "scipy", "numba", "pandas")


@functools.lru_cache(maxsize=1)
def code_version() -> str:
    """`git describe --always --dirty` of the source tree, or "unknown" outside
    git: as this process first asked, which the `workbench` command does before
    its verb runs. A run's own writes are tracked files too (`--update-committed`
    rewrites diagnosis.json before the fleet file records the code): asked
    again after them, git would call the code that made them dirty."""
    try:
        rev = subprocess.run(["git", "-C", str(ROOT), "describe", "--always", "--dirty"],
                             capture_output=True, text=True, timeout=5)
        return rev.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


# A case, data sheet, property table or diagnosis is at most a few hundred kB of
# text; anything over this is refused before it is read (not a 2 GB read, not
# an endless /dev/zero).
MAX_TEXT_BYTES = 50_000_000


def read_text_limited(path: str | Path, what: str, max_bytes: int = MAX_TEXT_BYTES) -> str:
    """The UTF-8 text of `path` (a `what`, named in messages); InputError
    unread when it is missing, not a regular file or over `max_bytes`."""
    from workbench.errors import InputError
    p = Path(path)
    try:
        if not p.is_file():
            raise InputError(f"{p}: {what} " + ("is not a file" if p.exists() else "not found"))
        size = p.stat().st_size
        if size > max_bytes:
            raise InputError(f"{p}: {what} is {size} bytes, over the {max_bytes} byte limit")
        return p.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"{p}: {what} is not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except OSError as exc:
        raise InputError(f"{p}: cannot read the {what} ({exc.strerror or exc})") from None


def project_path(path: str | Path) -> str:
    """`path` relative to the project (a results file names no folder of the
    machine that wrote it); a file outside the project by its name alone."""
    p = Path(path)
    try:
        return p.resolve().relative_to(ROOT).as_posix()
    except ValueError:
        return p.name


def file_sha256(path: str | Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def source_sha256(modules: Iterable[ModuleType]) -> dict[str, str]:
    """SHA-256 of the source files of `modules` (every .py file of a package), by path
    relative to the repository: exact even when the code is not committed."""
    out = {}
    for mod in modules:
        path = Path(mod.__file__).resolve()
        files = sorted(path.parent.glob("*.py")) if path.name == "__init__.py" else [path]
        for f in files:
            try:
                name = str(f.relative_to(ROOT))
            except ValueError:
                name = str(f)
            out[name] = file_sha256(f)
    return out


def dependency_versions(names: Iterable[str] = DEPENDENCIES) -> dict[str, str | None]:
    """Installed version of each distribution (None when it is not installed)."""
    out = {}
    for name in names:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    return out


def json_safe(v: Any) -> Any:
    """`v` with numpy scalars and arrays as Python values, tuples as lists, keys as
    strings and non-finite floats as None (strict JSON has no NaN or inf)."""
    if isinstance(v, dict):
        return {str(k): json_safe(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [json_safe(x) for x in v]
    if isinstance(v, np.ndarray):
        return json_safe(v.tolist())
    if isinstance(v, (np.bool_, np.integer, np.floating)):
        return json_safe(v.item())
    if isinstance(v, float):
        return v if math.isfinite(v) else None
    return v


class FileCache:
    """Values parsed from files, keyed on the resolved path and kept while the
    file's modification time and size stay the same. The cached value is
    shared by every caller: treat it as read-only."""

    def __init__(self) -> None:
        self._entries: dict[Path, tuple[tuple[int, int], Any]] = {}

    def get(self, path: str | Path, read: Callable[[Path], Any]) -> Any:
        """`read(path)`, or its value from an earlier call on the unchanged file."""
        p = Path(path)
        try:
            st = p.stat()
        except OSError:
            return read(p)   # the reader names the missing or unreadable file
        key, stamp = p.resolve(), (st.st_mtime_ns, st.st_size)
        hit = self._entries.get(key)
        if hit is not None and hit[0] == stamp:
            return hit[1]
        value = read(p)
        self._entries[key] = (stamp, value)
        return value
