"""The `workbench` group, its exit-code contract and its top-level guard."""
from __future__ import annotations

import datetime as _dt
import os
import tempfile
import traceback
from pathlib import Path

import click

from workbench.cli.compare import compare
from workbench.cli.diagnose import diagnose
from workbench.cli.logs import logs
from workbench.cli.properties import properties
from workbench.cli.run import run
from workbench.cli.validate import validate
from workbench.errors import (BAD_INPUT, EXIT_BAD_INPUT, EXIT_GATE_FAILED, EXIT_INTERNAL, EXIT_INTERRUPTED,
                              EXIT_NUMERICAL, NUMERICAL)
from workbench.provenance import code_version

HELP = f"""Hose-and-drogue aerial refueling simulation and validation workbench.

\b
Exit status of every command:
  0  success (validate: every gate passes, every finding as expected)
  {EXIT_GATE_FAILED}  validate: a gate failed, or a finding moved out of its band
  {EXIT_BAD_INPUT}  bad input: a case, CLI option, log or hardware file (one line names it)
  {EXIT_NUMERICAL}  numerical failure: the solver diverged or its static solve failed
  {EXIT_INTERNAL}  internal error: a defect; the traceback is written to a log file
  {EXIT_INTERRUPTED}  interrupted (Ctrl-C)
"""


def _traceback_file(exc: BaseException) -> Path:
    """Write the traceback where it cannot land in the repository: the system temp folder."""
    stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    path = Path(tempfile.gettempdir()) / f"workbench-internal-error-{stamp}-{os.getpid()}.log"
    path.write_text("".join(traceback.format_exception(exc)))
    return path


class GuardedGroup(click.Group):
    """A click group whose commands end in the exit-code contract: bad input
    and numerical failures as one line, anything unexpected as one line with
    the traceback in a file, never a traceback on screen."""

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except (click.exceptions.Exit, click.Abort):
            raise                                    # click's own: --help, a declined prompt
        except click.UsageError as exc:
            # one line naming the option, as for any other bad input (click prints three)
            hint = f" (see 'workbench {exc.ctx.command_path.split(' ', 1)[-1]} --help')" if exc.ctx else ""
            self._fail(ctx, EXIT_BAD_INPUT, f"Error: {exc.format_message()}{hint}")
        except KeyboardInterrupt:
            # not the gate-failed 1 click would give: the shell's code for SIGINT
            self._fail(ctx, EXIT_INTERRUPTED, "interrupted (Ctrl-C); outputs may be incomplete")
        except click.ClickException as exc:
            exc.exit_code = EXIT_BAD_INPUT           # the verbs raise these only for bad input
            raise
        except BAD_INPUT as exc:
            self._fail(ctx, EXIT_BAD_INPUT, f"error: {exc}")
        except NUMERICAL as exc:
            self._fail(ctx, EXIT_NUMERICAL, f"numerical failure: {exc}")
        except Exception as exc:  # noqa: BLE001 - the guard: every defect ends in one line
            try:
                where = f"traceback in {_traceback_file(exc)}"
            except OSError as werr:
                where = f"traceback not written: {werr}"
            self._fail(ctx, EXIT_INTERNAL, f"internal error: {type(exc).__name__}: {exc} ({where})")

    @staticmethod
    def _fail(ctx: click.Context, code: int, message: str):
        click.echo(f"workbench: {' '.join(message.splitlines())}", err=True)
        ctx.exit(code)


@click.group(cls=GuardedGroup, help=HELP, context_settings=dict(help_option_names=["-h", "--help"]))
@click.version_option(package_name="workbench")
def cli() -> None:
    # the code version results record, taken before the verb writes any of them
    code_version()


for _command in (run, compare, validate, logs, properties, diagnose):
    cli.add_command(_command)


def main() -> None:
    cli.main(prog_name="workbench", standalone_mode=True)
