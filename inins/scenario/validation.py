"""Turn pydantic validation errors into one readable :class:`InputError`.

Each pydantic error has a location (``("motion", 3, "hold", "duration_s")``,
union tags included) and a type. The location is mapped onto the scenario data
(tags that are not keys are dropped) to give a key path such as
``motion[3].duration_s``, whose line comes from the YAML line map. Values set
by ``--set`` are attributed to that option instead of a line.
"""

import difflib
import typing

from inins.exceptions import InputError
from inins.scenario.yaml_source import format_path, line_of

_MAX_LISTED = 5
_NO_INPUT_SHOWN = {"check_syntax", "value_error", "too_long", "too_short"}
_SIMPLE = {
    "float_parsing": "expected a number",
    "float_type": "expected a number",
    "int_parsing": "expected an integer",
    "int_type": "expected an integer",
    "int_from_float": "expected an integer",
    "bool_parsing": "expected true or false",
    "bool_type": "expected true or false",
    "string_type": "expected text",
    "finite_number": "expected a finite number (NaN and infinity are not allowed)",
    "list_type": "expected a list",
    "tuple_type": "expected a list",
    "dict_type": "expected a mapping (key: value)",
    "model_type": "expected a mapping (key: value)",
    "model_attributes_type": "expected a mapping (key: value)",
}
_BOUNDS = {
    "greater_than": ">",
    "greater_than_equal": ">=",
    "less_than": "<",
    "less_than_equal": "<=",
}


class KeyPathError(ValueError):
    """A validator's error about a key below the model being validated.

    Raise it from a ``model_validator`` to point the message (and its line)
    at the key, not at the whole mapping::

        raise KeyPathError(("motion", i, "axis"), "the table has no roll gimbal")

    Parameters
    ----------
    path : tuple of str or int
        Key path relative to the model that raises.
    message : str
    """

    def __init__(self, path, message):
        super().__init__(message)
        self.path = tuple(path)


def _messages(err: dict, path: tuple) -> str:
    """User-facing text for one pydantic error."""
    kind, ctx = err["type"], err.get("ctx") or {}
    if kind in _SIMPLE:
        return _SIMPLE[kind]
    if kind in _BOUNDS:
        limit = next(iter(ctx.values()), "?")
        return f"must be {_BOUNDS[kind]} {limit}{_unit_word(path)}"
    if kind == "literal_error":
        return f"expected one of {ctx.get('expected', '?')}"
    if kind == "too_long":
        return f"expected at most {ctx.get('max_length')} items, got {ctx.get('actual_length')}"
    if kind == "too_short":
        return f"expected at least {ctx.get('min_length')} items, got {ctx.get('actual_length')}"
    if kind == "value_error":
        return str(ctx.get("error", err["msg"]))
    msg = err["msg"]
    return msg[:1].lower() + msg[1:]


def _unit_word(path) -> str:
    from inins.scenario.labunits import unit_of

    last = path[-1] if path else None
    found = unit_of(last) if isinstance(last, str) else None
    return f" {found[0]}" if found else ""


def _shown(value) -> str:
    if isinstance(value, dict | list | tuple):
        return ""
    if isinstance(value, bool):
        text = str(value).lower()
    elif value is None:
        text = "null"
    else:
        text = repr(value)
    return f", got {text[:60]}"


def data_path(loc, data) -> tuple:
    """Map a pydantic location onto the scenario data, dropping union tags.

    Elements found in the data are kept; the last element is kept even when
    absent (a missing key); other absent elements are tags and are dropped.
    """
    path, node = [], data
    for i, part in enumerate(loc):
        last = i == len(loc) - 1
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif isinstance(node, list) and isinstance(part, int) and 0 <= part < len(node):
            node = node[part]
        elif last and _can_hold(node, part):
            node = None  # a missing key of a mapping or a missing item of a list
        else:
            continue
        path.append(part)
    return tuple(path)


def _can_hold(node, part) -> bool:
    if isinstance(node, dict):
        return isinstance(part, str)
    return isinstance(node, list) and isinstance(part, int)


def _allowed_keys(model_cls, path) -> list[str] | None:
    """Keys the model accepts at the mapping holding ``path[-1]`` (best effort)."""
    cls = model_cls
    for part in path[:-1]:
        if isinstance(part, int):
            continue
        field = getattr(cls, "model_fields", {}).get(part)
        if field is None:
            return None
        cls = _single_model(field.annotation)
        if cls is None:
            return None
    return sorted(getattr(cls, "model_fields", {}))


def _single_model(annotation):
    """The one pydantic model class inside an annotation (list/Optional/...)."""
    if isinstance(annotation, type) and hasattr(annotation, "model_fields"):
        return annotation
    found = [m for m in map(_single_model, typing.get_args(annotation)) if m is not None]
    return found[0] if len(found) == 1 else None


def _describe(err, data, model_cls) -> tuple[tuple, str]:
    path = data_path(err["loc"], data)
    kind = err["type"]
    if kind == "missing":
        if path and isinstance(path[-1], int):
            return path, f"missing list item (expected at least {path[-1] + 1} items)"
        return path, "required key is missing"
    if kind in ("union_tag_invalid", "union_tag_not_found"):
        ctx = err.get("ctx") or {}
        tag_key = str(ctx.get("discriminator", "")).strip("'")
        if kind == "union_tag_not_found":
            return (*path, tag_key), "required key is missing (it selects the kind of item)"
        return (*path, tag_key), (
            f"unknown {tag_key} {ctx.get('tag')!r}; expected one of {ctx.get('expected_tags')}"
        )
    error = (err.get("ctx") or {}).get("error")
    if kind == "value_error" and isinstance(error, KeyPathError):
        return (*path, *error.path), str(error)
    if kind == "extra_forbidden":
        allowed = _allowed_keys(model_cls, path) if path else None
        text = "unknown key"
        if allowed:
            close = difflib.get_close_matches(str(path[-1]), allowed, n=1)
            text += f"; did you mean {close[0]!r}?" if close else ""
            text += f" (allowed here: {', '.join(allowed)})"
        return path, text
    shown = "" if kind in _NO_INPUT_SHOWN else _shown(err.get("input"))
    return path, _messages(err, path) + shown


def to_input_error(exc, *, data, lines, source, model_cls, overrides=None) -> InputError:
    """One :class:`InputError` for a pydantic ``ValidationError``.

    Parameters
    ----------
    exc : pydantic.ValidationError
    data : dict
        The scenario data that was validated (after overrides).
    lines : dict
        Key path -> line, from :func:`inins.scenario.yaml_source.parse_yaml`.
    source : str
        Scenario file name.
    model_cls : type
        The scenario model (for "did you mean" on unknown keys).
    overrides : dict, optional
        Key path -> ``--set`` text, for values that came from the command line.

    Returns
    -------
    InputError
        Names the first problem (file, line, key path, expected); further
        problems are listed one per line after it.
    """
    overrides = overrides or {}
    merged: dict = {}
    for err in exc.errors():
        path, text = _describe(err, data, model_cls)
        if text not in merged.setdefault(path, []):
            merged[path].append(text)
    described = [(path, " or ".join(texts)) for path, texts in merged.items()]
    first_path, first_text = described[0]
    line = None
    origin = _override_for(first_path, overrides)
    if origin:
        first_text += f" (from --set {origin})"
    else:
        line = line_of(lines, first_path)
    more = [
        f"  also {format_path(p) or '(top level)'}"
        f"{'' if _override_for(p, overrides) else _at_line(lines, p)}: {t}"
        for p, t in described[1 : _MAX_LISTED + 1]
    ]
    if len(described) > _MAX_LISTED + 1:
        more.append(f"  ... and {len(described) - _MAX_LISTED - 1} more")
    message = "\n".join([first_text, *more])
    return InputError(message, source=source, key=format_path(first_path) or None, line=line)


def _at_line(lines, path) -> str:
    line = line_of(lines, path)
    return f" (line {line})" if line else ""


def _override_for(path, overrides) -> str | None:
    """The ``--set`` that produced ``path`` (the path or one of its parents)."""
    path = tuple(path)
    for opath, text in overrides.items():
        n = min(len(path), len(opath))
        if path[:n] == tuple(opath)[:n]:
            return text
    return None
