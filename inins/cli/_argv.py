"""The common command line of a run, parsed without loading Typer.

``inins CMD [SCENARIO.yaml] [-o OUTDIR] [--set KEY.PATH=VALUE ...] [--seed N]
[--debug] [--plot] [--force]`` is what nearly every run looks like. Typer (with the
click parser and the pydantic type adapters it builds for each parameter at parse
time) costs about 0.1 s of a run that computes for 0.2 s, so :func:`parse_run`
reads this form directly and gives the same arguments Typer's parse of
:func:`inins.cli._runner.make_command` gives (a test compares them on many command
lines). Anything else -- help, ``--version``, other commands, an option given
twice, a value that looks like an option, ``--``, short-option clusters, a value
Typer would have to convert or reject -- returns None and Typer parses the
command line as before, with its own messages.
"""

import re

_VALUED = {"-o": "outdir", "--outdir": "outdir", "--set": "overrides", "--seed": "seed"}
_FLAGS = {"--debug": "debug", "--plot": "plot", "--force": "force"}
_SEED = re.compile(r"[0-9]{1,19}")


def _plain(token: str) -> bool:
    """A token Typer would take as it is: valid UTF-8, no NUL, not empty."""
    if not token or "\0" in token:
        return False
    try:
        token.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def parse_run(argv, commands):
    """``(spec, arguments)`` for :func:`inins.cli._runner.run_command` when ``argv``
    (without the program name) is the plain form of a run of one of ``commands``;
    else None (Typer parses it)."""
    if not argv or not all(_plain(t) for t in argv):
        return None
    spec = next((s for s in commands if s.name == argv[0]), None)
    if spec is None:
        return None
    args = {"scenario": None, "outdir": None, "overrides": [], "seed": None}
    args |= dict.fromkeys(_FLAGS.values(), False)
    seen = set()
    tokens = iter(argv[1:])
    for token in tokens:
        if not token.startswith("-"):
            if args["scenario"] is not None:
                return None
            args["scenario"] = token
            continue
        name, eq, value = token.partition("=")
        if name in _FLAGS and not eq:
            key = _FLAGS[name]
        elif name in _VALUED and (not eq or name.startswith("--")):
            key = _VALUED[name]
            if not eq:
                value = next(tokens, None)
                if value is None or value.startswith("-"):
                    return None
            elif not value or value.startswith("-"):
                return None
        else:
            return None
        if key in seen and key != "overrides":
            return None
        seen.add(key)
        if key in _FLAGS.values():
            args[key] = True
        elif key == "overrides":
            args["overrides"].append(value)
        elif key == "seed":
            if not _SEED.fullmatch(value):
                return None
            args["seed"] = int(value)
        else:
            args[key] = value
    if args["scenario"] is not None:
        from pathlib import Path

        args["scenario"] = Path(args["scenario"])
    return spec, args
