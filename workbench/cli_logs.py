"""`workbench logs ...` verbs (owned by the flight-log ingest work)."""
import click


@click.group()
def logs() -> None:
    """Inspect and analyze flight and bench logs."""
