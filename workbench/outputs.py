"""Where the verbs write: one folder per run, named by `--out`, checked before
any computing, never escaped, never silently overwritten, never shared by two
runs at once.

* `safe_name` maps an id from a file (a case `id`, a log's `test_id`) to a
  file name that cannot leave its folder (`../../x` becomes `x`).
* `claim(out, results, force)` makes the folder, proves it writable, refuses it
  when another run's results are already there (unless `--force`) and locks
  it for the run: a second run into the same folder while the first is still
  writing is refused (exit 2) instead of mixing or losing reports. The lock
  is released when the `with` block ends; one left by a killed run (its
  process gone) is taken over.

A re-run into a folder that already holds results is refused with a message
naming `--force`; a fresh folder (a clean clone's `reports/out`, CI's case) is
simply made.
"""
from __future__ import annotations

import contextlib
import datetime as _dt
import os
import re
import tempfile
from pathlib import Path
from typing import Iterable, Iterator

from workbench.errors import InputError

LOCK = ".workbench.lock"
# an id that becomes a file name: letters, digits, '.', '_', '-', not starting with '.'
SAFE_ID = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9._-]{0,99}")


def is_safe_id(text: str) -> bool:
    return bool(SAFE_ID.fullmatch(text))


def safe_name(text: str) -> str:
    """`text` as a file name inside its folder: every character outside
    [A-Za-z0-9._-] (path separators included) becomes '_', leading dots are
    dropped, at most 100 characters; never empty."""
    name = re.sub(r"[^A-Za-z0-9._-]", "_", str(text)).lstrip(".")[:100]
    return name or "_"


def timestamped(parent: str | Path, prefix: str) -> Path:
    """A folder under `parent` that does not exist yet: PREFIX-YYYYmmdd-HHMMSS[-n]."""
    stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y%m%d-%H%M%S")
    base = Path(parent) / f"{prefix}-{stamp}"
    path, n = base, 1
    while path.exists():
        n += 1
        path = base.with_name(f"{base.name}-{n}")
    return path


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True
    return True


def _lock(out: Path, option: str) -> Path:
    lock = out / LOCK
    for _ in range(2):
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            try:
                pid = int(lock.read_text().split()[0])
            except (OSError, ValueError, IndexError):
                pid = -1
            if pid > 0 and not _pid_alive(pid):
                lock.unlink(missing_ok=True)      # left by a run that was killed: take it over
                continue
            raise InputError(f"{option} {out}: another run (process {pid}) is writing there ({lock}); "
                             f"wait for it, or choose another {option}") from None
        with os.fdopen(fd, "w") as fh:
            fh.write(f"{os.getpid()}\n")
        return lock
    raise InputError(f"{option} {out}: cannot take the lock {lock}")


def _writable_folder(out: Path, option: str) -> None:
    try:
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=out):
            pass
    except OSError as exc:
        raise InputError(f"{option} {out}: cannot write there ({exc.strerror or exc})") from None


def writable_file(path: str | Path | None, option: str) -> None:
    """Refuse, before any computing, a file `option` names (--mcap, --animate)
    that cannot be written: its folder unwritable, or the path a folder."""
    if path is None:
        return
    p = Path(path)
    if p.is_dir():
        raise InputError(f"{option} {p}: is a folder")
    _writable_folder(p.parent, option)


@contextlib.contextmanager
def claim(out: str | Path, results: Iterable[str] = (), force: bool = False,
          option: str = "--out") -> Iterator[Path]:
    """The output folder `out`, made, checked writable and locked for this run.

    `results`: names (relative to `out`) a previous run would have left; if
    one is there the folder holds another run's results and is refused unless
    `force`. Raises InputError (exit 2) naming `option` before any computing."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError(f"{option} {out}: exists and is not a folder")
    _writable_folder(out, option)
    lock = _lock(out, option)
    try:
        if not force:
            old = [r for r in results if (out / r).exists()]
            if old:
                raise InputError(f"{option} {out}: holds another run's results ({old[0]}); "
                                 f"choose another {option}, or give --force to overwrite them")
        yield out
    finally:
        lock.unlink(missing_ok=True)

