"""Scenario YAML: parse with line numbers, apply ``--set`` overrides.

The loader is PyYAML's safe loader with three YAML 1.2 fixes, so that a
scenario means what it looks like:

- only ``true``/``false`` are booleans (``yes``, ``no``, ``on``, ``off`` stay
  text; in YAML 1.1 a key ``on:`` silently becomes ``True``);
- ``1e-3`` and ``2.5e3`` are numbers (YAML 1.1 needs ``1.0e-3``);
- dates stay text (``2024-05-01`` is not turned into a ``datetime.date``).

Duplicate keys in one mapping are an error (YAML 1.1 keeps the last silently).

Key paths are tuples of ``str`` keys and ``int`` list indexes and are shown as
``imu.gyro.bias_dph[1]`` or ``motion[3].duration_s``. ``--set`` accepts that form
and also ``motion.3.duration_s``.
"""

import re

import yaml

from inins.exceptions import InputError

_BOOL = "tag:yaml.org,2002:bool"
_FLOAT = "tag:yaml.org,2002:float"
_TIMESTAMP = "tag:yaml.org,2002:timestamp"
_MAX_NODES = 200_000
MAX_DEPTH = 64
"""Deepest nesting of mappings and lists a scenario may have (the shipped ones reach 5)."""
MAX_BYTES = 1 << 20
"""Largest scenario text (1 MB: 20,000 observability segments); a longer list belongs
in a data file (trajectory:, flight:)."""
_KEY_RE = re.compile(r"^[A-Za-z_][\w-]*(?:\[\d+\])*(?:\.(?:[\w-]+)(?:\[\d+\])*)*$")


class _Loader(yaml.SafeLoader):
    """Safe loader with YAML 1.2 booleans, exponent floats and text dates."""


_Loader.yaml_implicit_resolvers = {
    first: [(tag, rx) for tag, rx in resolvers if tag not in (_BOOL, _TIMESTAMP)]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
_Loader.add_implicit_resolver(
    _BOOL, re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$"), list("tTfF")
)
_Loader.add_implicit_resolver(
    _FLOAT,
    re.compile(r"^[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)[eE][-+]?[0-9]+$"),
    list("-+0123456789."),
)


def format_path(path) -> str:
    """Show a key path as ``a.b[1].c``.

    Parameters
    ----------
    path : sequence of str or int
        Mapping keys and list indexes from the top of the scenario.

    Returns
    -------
    str
        ``""`` for the empty path (the whole scenario).
    """
    out = ""
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += f".{part}" if out else str(part)
    return out


def parse_yaml(text: str, source: str) -> tuple[dict, dict]:
    """Parse scenario text into data and a key-path -> line map.

    Parameters
    ----------
    text : str
        YAML text.
    source : str
        File name for messages.

    Returns
    -------
    data : dict
        The parsed scenario (an empty document gives ``{}``).
    lines : dict
        Key path tuple -> 1-based line of the key (or list item).

    Raises
    ------
    InputError
        Syntax error (with line and column), duplicate key, or a top level
        that is not a mapping.
    """
    if len(text) > MAX_BYTES:
        raise InputError(
            f"scenario text of {len(text) / 1e6:.3g} MB, more than the {MAX_BYTES >> 20} MB a "
            "scenario may hold (long lists of segments or steps belong in a data file)",
            source=source,
        )
    _check_depth(text, source)
    loader = _Loader(text)
    try:
        node = loader.get_single_node()
        lines: dict = {}
        if node is not None:
            _map_lines(node, (), lines, source, set(), [0])
        data = loader.construct_document(node) if node is not None else None
    except yaml.MarkedYAMLError as exc:
        raise _syntax_error(exc, source) from None
    except yaml.YAMLError as exc:
        raise InputError(f"cannot read YAML: {exc}", source=source) from None
    finally:
        loader.dispose()
    if data is None:
        return {}, lines
    if not isinstance(data, dict):
        raise InputError(
            f"expected a mapping of keys (key: value) at the top level, got {_kind(data)}",
            source=source,
            line=node.start_mark.line + 1,
        )
    return data, lines


def _check_depth(text: str, source: str) -> None:
    """Refuse nesting deeper than :data:`MAX_DEPTH` before the (recursive) composer sees
    it; the event parser is iterative. Syntax errors are left to the composer."""
    depth, events = 0, 0
    loader = _Loader(text)
    try:
        while loader.check_event():
            event = loader.get_event()
            events += 1
            if isinstance(event, yaml.CollectionStartEvent):
                depth += 1
                if depth > MAX_DEPTH:
                    raise InputError(
                        f"nested more than {MAX_DEPTH} levels deep (mappings and lists)",
                        source=source,
                        line=event.start_mark.line + 1,
                    )
            elif isinstance(event, yaml.CollectionEndEvent):
                depth -= 1
            if events > 2 * _MAX_NODES:
                raise InputError(
                    f"scenario too large (more than {_MAX_NODES} YAML nodes)", source=source
                )
    except yaml.YAMLError:
        return
    finally:
        loader.dispose()


def _syntax_error(exc, source) -> InputError:
    mark = exc.problem_mark or exc.context_mark
    what = exc.problem or exc.context or "invalid YAML"
    if exc.context and exc.problem:
        what = f"{exc.problem} ({exc.context})"
    line = mark.line + 1 if mark else None
    col = f", column {mark.column + 1}" if mark else ""
    return InputError(f"YAML syntax error{col}: {what}", source=source, line=line)


def _map_lines(node, path, lines, source, active, count) -> None:
    """Record the line of every key and list item; reject duplicate keys."""
    count[0] += 1
    if count[0] > _MAX_NODES:
        raise InputError(f"scenario too large (more than {_MAX_NODES} YAML nodes)", source=source)
    if id(node) in active:  # a recursive alias: its lines are already mapped
        return
    active.add(id(node))
    if isinstance(node, yaml.MappingNode):
        seen: dict = {}
        for key_node, value_node in node.value:
            key = key_node.value if isinstance(key_node, yaml.ScalarNode) else str(key_node)
            line = key_node.start_mark.line + 1
            if key == "<<":
                _map_lines(value_node, path, lines, source, active, count)
                continue
            if key in seen:
                raise InputError(
                    f"duplicate key {key!r} (first defined at line {seen[key]})",
                    source=source,
                    key=format_path((*path, key)),
                    line=line,
                )
            seen[key] = line
            lines[(*path, key)] = line
            _map_lines(value_node, (*path, key), lines, source, active, count)
    elif isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            lines[(*path, i)] = item.start_mark.line + 1
            _map_lines(item, (*path, i), lines, source, active, count)
    active.discard(id(node))


def line_of(lines: dict, path) -> int | None:
    """Line of ``path``, or of its nearest ancestor present in ``lines``."""
    path = tuple(path)
    while path:
        if path in lines:
            return lines[path]
        path = path[:-1]
    return None


def dump_yaml(data: dict) -> str:
    """YAML text of ``data`` (keys in their given order)."""
    return yaml.safe_dump(data, sort_keys=False, allow_unicode=True, default_flow_style=None)


def parse_override(item: str) -> tuple[tuple, object]:
    """Split one ``--set KEY.PATH=VALUE`` into a key path and a YAML value.

    Parameters
    ----------
    item : str
        ``imu.gyro.bias_dph=[1, 2, 3]``, ``motion.3.duration_s=60`` or
        ``motion[3].duration_s=60``. The value is parsed as YAML, so numbers,
        booleans, lists and mappings work; an empty value is null.

    Returns
    -------
    path : tuple
        Keys (str) and list indexes (int, for all-digit parts).
    value : object

    Raises
    ------
    InputError
        Missing ``=``, a malformed key path or a value that is not valid YAML.
    """
    key, sep, raw = item.partition("=")
    key = key.strip()
    if not sep or not _KEY_RE.match(key):
        raise InputError(
            f"--set expects KEY.PATH=VALUE (for example imu.gyro.bias_dph=[1, 0, 0]), got {item!r}"
        )
    path: list = []
    for part in re.findall(r"[^.\[\]]+|\[\d+\]", key):
        if part.startswith("["):
            path.append(int(part[1:-1]))
        else:
            path.append(int(part) if part.isdigit() else part)
    try:
        _check_depth(raw, f"--set {key}")
        value = yaml.load(raw, Loader=_Loader)
    except yaml.YAMLError as exc:
        problem = getattr(exc, "problem", None) or str(exc)
        raise InputError(f"--set {item}: the value is not valid YAML: {problem}") from None
    return tuple(path), value


def apply_override(data: dict, path: tuple, value, item: str) -> None:
    """Set ``value`` at ``path`` in ``data`` (in place).

    Missing mapping keys along the path are created (the scenario model then
    rejects keys it does not know); list indexes must exist.

    Raises
    ------
    InputError
        An index out of range, or a path that runs through a scalar.
    """
    node = data
    for depth, part in enumerate(path):
        last = depth == len(path) - 1
        where = format_path(path[:depth]) or "the top level"
        if isinstance(node, list):
            if not isinstance(part, int):
                raise InputError(f"--set {item}: {where} is a list; use an index such as .0")
            if not 0 <= part < len(node):
                raise InputError(
                    f"--set {item}: index {part} is out of range ({where} has {len(node)} items)"
                )
        elif isinstance(node, dict):
            part = _dict_key(node, part)
            if not last and node.get(part) is None:
                if isinstance(path[depth + 1], int):
                    raise InputError(
                        f"--set {item}: {format_path(path[: depth + 1])} is not in the "
                        "scenario, so it has no items to index; set the whole list instead"
                    )
                node[part] = {}
        else:
            raise InputError(f"--set {item}: {where} is {_kind(node)}, not a mapping or a list")
        if last:
            node[part] = value
        else:
            node = node[part]


def _dict_key(node: dict, part):
    """The key of ``node`` that ``part`` names (int parts may be str keys)."""
    if isinstance(part, int) and part not in node:
        return str(part)
    return part


def _kind(value) -> str:
    """Short description of a YAML value for messages."""
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, int | float):
        return f"a number ({value!r})"
    if isinstance(value, str):
        return f"text ({value!r})"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, dict):
        return "a mapping"
    return type(value).__name__
