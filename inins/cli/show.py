"""``inins show FILE.h5``: what a results file holds."""

from pathlib import Path
from typing import Annotated

import typer

from inins.cli._runner import guarded


def show(
    file: Annotated[Path, typer.Argument(metavar="FILE.h5", help="An inins results file.")],
    as_json: Annotated[
        bool, typer.Option("--json", help="Print only the summary, as summary.json would hold it.")
    ] = False,
    scenario: Annotated[
        bool, typer.Option("--scenario", help="Print only the scenario YAML the run used.")
    ] = False,
    debug: Annotated[bool, typer.Option("--debug", help="Show the traceback of an error.")] = False,
) -> None:
    """Print a results file's provenance, summary and datasets (with units and frames)."""
    raise typer.Exit(guarded("inins show", debug, lambda: _show(file, as_json, scenario)))


def _show(file: Path, as_json: bool, scenario: bool) -> int:
    from rich.text import Text

    from inins.cli._display import console, print_datasets, print_summary
    from inins.io.hdf5 import list_datasets, read_provenance, read_summary
    from inins.io.summary import summary_text

    summary = read_summary(file)
    prov = read_provenance(file)
    if as_json:
        typer.echo(summary_text(summary), nl=False)
        return 0
    if scenario:
        typer.echo(prov.get("scenario_yaml", ""), nl=False)
        return 0
    out = console()
    for key in ("command", "inins_version", "created_utc", "scenario_source", "seed", "platform"):
        out.print(Text(f"{key:16s}{prov.get(key, '')}"))
    for item in prov.get("scenario_overrides") or []:
        out.print(Text(f"{'override':16s}--set {item}"))
    out.print()
    print_summary(summary, out)
    out.print()
    print_datasets(list_datasets(file), out)
    return 0
