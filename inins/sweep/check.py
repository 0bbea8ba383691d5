"""``inins check PATH...``: run every scenario that states ``checks:``, the CI gate.

Which scenarios
    Each PATH is a YAML file, a folder (its ``*.yaml`` files, recursively) or a
    glob (``configs/**/*.yaml``). Files without a top-level ``checks:`` list are
    skipped (sweep files included: they have none).
Which command
    The command is the name of the folder the file is in (``configs/<command>/``);
    otherwise the one command whose scenario model accepts the file (the models
    forbid unknown keys, so e.g. ``configs/paper000/*.yaml`` are calibrate-bias
    scenarios); a file that fits none or several is bad input. A scenario file
    itself carries no ``command:`` key, so it stays runnable as ``inins CMD FILE``.
How
    Every file is loaded and validated first (bad input stops everything before any
    run); then each runs through :func:`inins.commands.execute.execute` with its own
    seed, on the sweep executors (local processes by default).
"""

import glob
from dataclasses import dataclass
from pathlib import Path

from inins.exceptions import InputError
from inins.sweep.executors import finished
from inins.sweep.worker import STATUS_ERROR, STATUS_FAILED, PointTask


@dataclass(frozen=True)
class CheckTarget:
    """One scenario to gate on: its file and command."""

    path: Path
    command: str


@dataclass(frozen=True)
class CheckOutcome:
    """One gated scenario: its target and worker record."""

    target: CheckTarget
    record: dict

    @property
    def passed(self) -> bool:
        return self.record["status"] == "passed"


def expand_paths(paths) -> list[Path]:
    """Files named by ``paths`` (files, folders, globs), sorted, without duplicates."""
    found = {}
    for item in paths:
        text = str(item)
        path = Path(text)
        if path.is_dir():
            matches = sorted(path.rglob("*.yaml")) + sorted(path.rglob("*.yml"))
        elif path.is_file():
            matches = [path]
        elif glob.has_magic(text):
            matches = [Path(p) for p in sorted(glob.glob(text, recursive=True))]
            matches = [p for p in matches if p.is_file()]
            if not matches:
                raise InputError("no file matches this pattern", source=text)
        else:
            raise InputError("no such file or folder", source=text)
        for m in matches:
            found.setdefault(m.resolve(), m)
    return list(found.values())


def has_checks(path: Path) -> bool:
    """True if the YAML file has a non-empty top-level ``checks:`` list."""
    from inins.scenario.base import _read_text
    from inins.scenario.yaml_source import parse_yaml

    data, _ = parse_yaml(_read_text(path, str(path)), str(path))
    return isinstance(data, dict) and bool(data.get("checks"))


def infer_command(path: Path) -> str:
    """The command of a scenario file (folder name, else the one model that fits)."""
    from inins.commands import COMMANDS, find_command
    from inins.commands.execute import load

    folder = path.resolve().parent.name
    names = [s.name for s in COMMANDS if s.available]
    if folder in names:
        return folder
    fits = []
    for name in names:
        try:
            load(find_command(name), path)
        except InputError:
            continue
        fits.append(name)
    if len(fits) != 1:
        said = "no command's scenario" if not fits else f"the scenarios of {', '.join(fits)}"
        raise InputError(
            f"cannot tell which command runs this file: it fits {said}; put it in a folder "
            "named after its command (configs/<command>/)",
            source=str(path),
        )
    return fits[0]


def collect(paths) -> tuple[list[CheckTarget], list[Path]]:
    """Targets (validated: each loads as its command's scenario) and skipped files."""
    from inins.commands import find_command
    from inins.commands.execute import load

    targets, skipped = [], []
    for path in expand_paths(paths):
        if not has_checks(path):
            skipped.append(path)
            continue
        command = infer_command(path)
        load(find_command(command), path)
        targets.append(CheckTarget(path, command))
    if not targets:
        raise InputError("no scenario with checks: found in " + ", ".join(map(str, paths)))
    return targets, skipped


def check_records(targets, ex):
    """Run every target on the entered executor ``ex``; yield each worker record as it
    finishes (its ``index`` the target's)."""
    tasks = [
        (PointTask(str(t.path), i, t.command, str(t.path.resolve()), (), None),)
        for i, t in enumerate(targets)
    ]
    for batch in finished(ex, tasks, len(tasks)):
        yield batch[0]


def failures(outcomes) -> list[str]:
    """One line per failed check or error: ``FILE: check 'EXPR' failed``."""
    lines = []
    for o in outcomes:
        rec = o.record
        if rec["status"] == STATUS_ERROR:
            lines.append(f"{o.target.path}: error: {rec['error']}")
        elif rec["status"] == STATUS_FAILED:
            for name, ok in rec["checks"]:
                if not ok:
                    lines.append(f"{o.target.path}: check failed: {name}")
    return lines
