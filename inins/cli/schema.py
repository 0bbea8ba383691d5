"""``inins schema CMD``: print the JSON Schema of a command's scenario."""

from typing import Annotated

import typer

from inins.cli._runner import guarded
from inins.commands import COMMANDS, find_command, load_command


def make_schema_command(commands=COMMANDS):
    """The ``schema`` command over a registry (tests pass their own)."""
    names = ", ".join(spec.name for spec in commands)

    def schema(
        command: Annotated[
            str, typer.Argument(metavar="CMD", help=f"Command whose scenario to describe: {names}.")
        ],
        debug: Annotated[
            bool, typer.Option("--debug", help="Show the traceback of an error.")
        ] = False,
    ) -> None:
        """Print the JSON Schema of a command's scenario (every key with its unit)."""
        raise typer.Exit(guarded("inins schema", debug, lambda: _print_schema(command, commands)))

    return schema


def schema_text(command: str, commands=COMMANDS) -> str:
    """JSON Schema of ``command``'s scenario model, indented JSON text."""
    import json

    module = load_command(find_command(command, commands))
    return json.dumps(module.SCENARIO_MODEL.model_json_schema(), indent=2)


def _print_schema(command, commands) -> int:
    typer.echo(schema_text(command, commands))
    return 0
