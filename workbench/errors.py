"""Errors the workbench reports to a user as one line (no traceback), and the
exit status of every `workbench` verb."""
from __future__ import annotations

from pathlib import PurePath
from typing import Mapping

from flighttest import LogError
from solver.chain import DivergenceError
from solver.statics import StaticSolveError

# The exit-code contract of every verb (README "Exit status", `workbench --help`).
# 0: success
EXIT_GATE_FAILED = 1     # validate: a gate failed or a finding changed
EXIT_BAD_INPUT = 2       # a case, CLI option, log or hardware file is wrong (click's usage errors too)
EXIT_NUMERICAL = 3       # the solver failed: a divergence or a static solve that did not converge
EXIT_INTERNAL = 4        # a defect: an unexpected exception (traceback written to a log file)
EXIT_INTERRUPTED = 130   # Ctrl-C (128 + SIGINT, as a shell reports it)


class InputError(ValueError):
    """Bad input: a file, field or parameter, named in the message, is wrong."""


class SimulationFailed(RuntimeError):
    """A candidate's simulation of one log failed; the message names the log,
    the effects and the solver's reason (its time and element when it says them)."""

    def __init__(self, path: str, effects: Mapping, exc: BaseException):
        self.path = str(path)
        self.effects = {k: dict(v) for k, v in effects.items()}
        self.reason = f"{type(exc).__name__}: {exc}"
        eff = "; ".join(f"{e} " + ", ".join(f"{k}={v:.4g}" for k, v in d.items()) for e, d in effects.items())
        super().__init__(f"{PurePath(str(path)).stem} with {eff or 'no effect'}: {self.reason}")


# what a bad file or option raises, wherever it is read
BAD_INPUT = (InputError, LogError)
# what the solver raises when the numbers fail (the message names the time and element)
NUMERICAL = (DivergenceError, StaticSolveError, SimulationFailed)


def exit_code_for(exc: BaseException) -> int:
    """The exit status an exception stands for under the contract above."""
    if isinstance(exc, BAD_INPUT):
        return EXIT_BAD_INPUT
    if isinstance(exc, NUMERICAL):
        return EXIT_NUMERICAL
    return EXIT_INTERNAL
