"""The one mapper: `fn` over jobs on local worker processes, or on a Dask
distributed cluster by scheduler address. `validate`, the diagnosis and its
selftest all map through it, so a campaign of many logs runs on a cluster the
same way a diagnosis does.

    with Mapper(workers=4) as m:              # or Mapper(scheduler="tcp://host:8786")
        results = m(fn, jobs)                 # in job order

`fn` and the jobs must pickle (module-level functions). A job's exception
propagates out of the call; callers that want the other jobs' results catch
inside `fn`.
"""
from __future__ import annotations

import os
from concurrent.futures import ProcessPoolExecutor
from typing import Callable, Iterable

from workbench.config import defaults
from workbench.errors import InputError


class Mapper:
    """`Mapper(workers, scheduler)(fn, jobs) -> [fn(job) for job in jobs]`.

    `scheduler`: a Dask scheduler address (the client connects on first use
    and closes with `close`); otherwise `workers` local processes (None: the
    `parallel.workers` default, one per core); one worker or one job runs in
    this process. `progress(result)` is called with each result in job order."""

    def __init__(self, workers: int | None = None, scheduler: str | None = None):
        if workers is not None and workers < 1:
            raise ValueError(f"workers must be at least 1, got {workers}")
        self.workers = workers or defaults["parallel.workers"] or os.cpu_count() or 1
        self.scheduler = scheduler
        self._client = None

    def __call__(self, fn: Callable, jobs: Iterable, progress: Callable | None = None) -> list:
        jobs = list(jobs)
        if self.scheduler:
            if self._client is None:
                self._client = _connect(self.scheduler)
            return _drain(self._client.gather(self._client.map(fn, jobs, pure=False)), progress)
        if self.workers <= 1 or len(jobs) <= 1:
            return _drain(map(fn, jobs), progress)
        with ProcessPoolExecutor(max_workers=min(self.workers, len(jobs))) as pool:
            return _drain(pool.map(fn, jobs), progress)

    def close(self) -> None:
        if self._client is not None:
            self._client.close()
            self._client = None

    def __enter__(self) -> "Mapper":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _connect(address: str):
    """A Dask client of the scheduler at `address`; one that cannot be reached
    is a bad --scheduler (exit 2), not a defect."""
    try:
        from distributed import Client
    except ImportError:
        raise InputError(f"--scheduler {address}: needs the 'distributed' package (pip install distributed)") from None
    try:
        return Client(address)
    except (OSError, ValueError) as exc:
        raise InputError(f"--scheduler {address}: cannot reach the Dask scheduler ({exc})") from None


def _drain(results: Iterable, progress: Callable | None) -> list:
    out = []
    for r in results:
        out.append(r)
        if progress:
            progress(r)
    return out
