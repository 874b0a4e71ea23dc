"""The `workbench` command line: one module per verb group (`main` holds the
group, the exit-code contract and the guard that keeps tracebacks off the
user's screen)."""
from workbench.cli.main import cli, main

__all__ = ["cli", "main"]
