"""One progress display for a whole command, from its first second to its
last: a tqdm line on stderr whose total grows as the work becomes known
(tuning, calibration, runs, report writing), naming the step under way."""
from __future__ import annotations

import sys
import time

from tqdm import tqdm


class Progress:
    """`add(n, what)` announces n more steps; `doing(what)` names the step under
    way; `done(what)` finishes one. It draws only on a terminal: disabled, or
    when `stream` (default stderr) is a pipe or a file (CI logs, captured
    output), it prints nothing."""

    def __init__(self, desc: str, enabled: bool = True, stream=None):
        self.t0 = time.perf_counter()
        stream = stream or sys.stderr
        self._bar = tqdm(total=0, desc=desc, unit="step", file=stream, leave=True, mininterval=0.5,
                         disable=not (enabled and stream.isatty()),
                         bar_format="{desc}: {n_fmt}/{total_fmt} steps [{elapsed}]{postfix}")
        self._bar.refresh()   # on screen at once, before any heavy import or computing

    def add(self, n: int, what: str = "") -> None:
        self._bar.total += n
        if what:
            self._bar.set_postfix_str(what, refresh=False)
        self._bar.refresh()

    def doing(self, what: str) -> None:
        self._bar.set_postfix_str(what)

    def done(self, what: str = "") -> None:
        if what:
            self._bar.set_postfix_str(what, refresh=False)
        self._bar.update(1)

    def close(self, keep: bool = True) -> None:
        """End the display; `keep=False` erases its line (an error message follows)."""
        self._bar.leave = keep
        self._bar.close()

    @property
    def elapsed_s(self) -> float:
        return time.perf_counter() - self.t0
