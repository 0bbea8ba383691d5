"""``inins schema CMD``: the keys of a command's scenario as a readable table (key path,
type, unit, default, meaning); ``--json`` prints the JSON Schema itself."""

import json
from typing import Annotated

import typer

from inins.cli._runner import guarded
from inins.commands import COMMANDS, find_command, load_command


def make_schema_command(commands=COMMANDS):
    """The ``schema`` command over a registry (tests pass their own)."""
    names = ", ".join([*(spec.name for spec in commands), "sweep (the sweep file)"])

    def schema(
        command: Annotated[
            str, typer.Argument(metavar="CMD", help=f"Command whose scenario to describe: {names}.")
        ],
        as_json: Annotated[
            bool, typer.Option("--json", help="Print the JSON Schema instead of the table.")
        ] = False,
        debug: Annotated[
            bool, typer.Option("--debug", help="Show the traceback of an error.")
        ] = False,
    ) -> None:
        """Describe a command's scenario: every key with its type, unit, default and meaning."""
        raise typer.Exit(
            guarded("inins schema", debug, lambda: _print_schema(command, commands, as_json))
        )

    return schema


def schema_dict(command: str, commands=COMMANDS) -> dict:
    """JSON Schema of ``command``'s scenario model (``sweep``: of the sweep file)."""
    if command == "sweep":
        from inins.scenario.sweep import SweepScenario

        return SweepScenario.model_json_schema()
    module = load_command(find_command(command, commands))
    return module.SCENARIO_MODEL.model_json_schema()


def schema_text(command: str, commands=COMMANDS) -> str:
    """JSON Schema of ``command``'s scenario model, indented JSON text."""
    return json.dumps(schema_dict(command, commands), indent=2)


def schema_rows(schema: dict) -> list[tuple]:
    """``(key path, type, unit, default, meaning)`` of every key, sections first-level
    in order; list items are ``key[]``, alternatives of a list (the motion steps) are
    ``key[] (kind)``."""
    defs = schema.get("$defs", {})
    rows: list[tuple] = []
    _walk(schema, "", defs, rows, set())
    return rows


def _resolve(node, defs):
    ref = node.get("$ref")
    return defs[ref.rsplit("/", 1)[-1]] if ref else node


def _variants(node, defs):
    """The alternatives of a property that are sections (anyOf/oneOf of $ref)."""
    options = node.get("anyOf") or node.get("oneOf") or []
    return [_resolve(o, defs) for o in options if "$ref" in o]


def _walk(node, prefix, defs, rows, seen):
    node = _resolve(node, defs)
    required = set(node.get("required", ()))
    for name, prop in node.get("properties", {}).items():
        path = f"{prefix}{name}"
        target = _resolve(prop, defs)
        sections = [target] if "properties" in target else _variants(prop, defs)
        items = prop.get("items") or next(
            (o.get("items") for o in prop.get("anyOf", []) if o.get("items")), None
        )
        if items is not None:
            sections = [_resolve(items, defs)] if "$ref" in items else _variants(items, defs)
            if sections:
                default = _default(prop, name in required)
                rows.append((f"{path}[]", "list", "", default, _meaning(prop, target)))
                for section in sections:
                    kind = section.get("properties", {}).get("kind", {}).get("const")
                    sub = f"{path}[] ({kind})." if kind and len(sections) > 1 else f"{path}[]."
                    key = (sub, section.get("title"))
                    if key not in seen:
                        _walk(section, sub, defs, rows, seen | {key})
                continue
        if sections:
            rows.append((path, "section", "", "", _meaning(prop, sections[0])))
            for section in sections:
                _walk(section, f"{path}.", defs, rows, seen)
            continue
        default = _default(prop, name in required)
        rows.append((path, _type(prop, defs), prop.get("unit", ""), default, _meaning(prop)))


def _type(prop, defs) -> str:
    if "const" in prop:
        return f"= {prop['const']}"
    if "enum" in prop:
        return " | ".join(str(v) for v in prop["enum"])
    options = prop.get("anyOf") or prop.get("oneOf")
    if options:
        return " or ".join(_type(o, defs) for o in options)
    kind = prop.get("type", "any")
    if kind == "array":
        inner = _type(prop.get("items", {}), defs)
        n = prop.get("minItems")
        size = f"{n}" if n is not None and n == prop.get("maxItems") else ""
        return f"list[{inner}]{size and ' x' + size}"
    bounds = [
        f"{op} {prop[key]:g}"
        for key, op in (
            ("exclusiveMinimum", ">"),
            ("minimum", ">="),
            ("exclusiveMaximum", "<"),
            ("maximum", "<="),
        )
        if key in prop and isinstance(prop[key], int | float)
    ]
    names = {"number": "number", "integer": "integer", "string": "text", "boolean": "true/false"}
    label = names.get(kind, kind)
    return f"{label} {', '.join(bounds)}" if bounds else label


def _default(prop, required) -> str:
    if "default" not in prop:
        return "required" if required else ""
    value = prop["default"]
    return "none" if value is None else json.dumps(value)


def _meaning(prop, section=None) -> str:
    text = prop.get("description") or (section or {}).get("description") or ""
    return " ".join(str(text).split())


def schema_table(command: str, commands=COMMANDS, width: int | None = None) -> str:
    """The readable table of ``command``'s scenario keys; with ``width`` (characters)
    the type and meaning columns wrap so that no line is longer (where the other
    columns leave room)."""
    from inins.results import format_table

    header = ["key", "type", "unit", "default", "meaning"]
    rows = schema_rows(schema_dict(command, commands))
    if width is None:
        return format_table(rows, header, fmt="")
    return _wrapped_table(rows, header, width)


def _wrapped_table(rows, header, width) -> str:
    """Columns of ``rows`` padded to their width, the type column wrapped at 28 and the
    last column at what the line leaves (at least 24), continuation lines indented."""
    import textwrap

    cells = [[str(c) for c in row] for row in rows]
    wrap = {1: 28}
    fixed = [max(len(header[j]), *(len(r[j]) for r in cells)) for j in range(len(header) - 1)]
    fixed[1] = min(fixed[1], wrap[1])
    room = width - sum(fixed) - 2 * (len(fixed))
    if room < 30:  # too narrow for a meaning column: the meaning under each key
        return _stacked_table(cells, width)
    out = []
    for row in [header, ["-" * w for w in fixed] + ["-" * min(room, 40)], *cells]:
        columns = [
            textwrap.wrap(row[j], wrap[j]) or [""] if j in wrap else [row[j]]
            for j in range(len(fixed))
        ]
        columns.append(textwrap.wrap(row[-1], room) or [""])
        for k in range(max(map(len, columns))):
            parts = [
                (c[k] if k < len(c) else "").ljust(w) for c, w in zip(columns, fixed, strict=False)
            ]
            last = columns[-1][k] if k < len(columns[-1]) else ""
            out.append(("  ".join(parts) + "  " + last).rstrip())
    return "\n".join(out)


def _stacked_table(cells, width) -> str:
    """One entry per key: ``key  type  [unit]  default: ...`` then the meaning indented,
    every line wrapped to ``width``."""
    import textwrap

    out = []
    for key, kind, unit, default, meaning in cells:
        head = "  ".join(p for p in (key, kind, f"[{unit}]" if unit else "") if p)
        if default:
            head += f"  (default {default})" if default != "required" else "  (required)"
        out += textwrap.wrap(head, width, subsequent_indent="      ") or [key]
        out += textwrap.wrap(meaning, width, initial_indent="    ", subsequent_indent="    ")
    return "\n".join(out)


def terminal_width() -> int | None:
    """Columns of the terminal (or ``COLUMNS``); None when the output is not a terminal."""
    import os
    import shutil
    import sys

    if "COLUMNS" in os.environ or sys.stdout.isatty():
        return shutil.get_terminal_size().columns
    return None


def _print_schema(command, commands, as_json=False) -> int:
    if as_json:
        typer.echo(schema_text(command, commands))
    else:
        table = schema_table(command, commands, terminal_width())
        what = "the sweep file" if command == "sweep" else f"inins {command}"
        typer.echo(f"scenario keys of {what} (--json for the JSON Schema)\n")
        typer.echo(table)
    return 0
