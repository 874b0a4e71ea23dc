"""The `workbench` command line."""
from __future__ import annotations

import sys

import click

from workbench.cli_logs import logs


class WorkbenchError(click.ClickException):
    """A one-line user-facing error (bad input, failed gate)."""


@click.group()
@click.version_option(package_name="workbench")
def cli() -> None:
    """Hose-and-drogue aerial refueling simulation and validation workbench."""


cli.add_command(logs)


def main() -> None:
    cli.main(prog_name="workbench", standalone_mode=True)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
