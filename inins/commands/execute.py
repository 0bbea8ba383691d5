"""Run one command end to end: scenario -> ``run`` -> CMD.h5 + CMD.txt + summary.json.

:func:`execute` is the one path every run takes, from the CLI and from a sweep:

1. imports the command module (:func:`inins.commands.load_command`);
2. loads the scenario (the file, or the shipped default) with its ``--set``
   overrides and validates it;
3. picks the seed: the given seed > the scenario's ``seed`` >
   :data:`inins.scenario.base.DEFAULT_SEED` (0); the seed used is recorded;
4. calls ``run(scenario, seed, sink=..., progress=...)``; with an output folder the
   sink streams into CMD.h5 on a writer thread;
5. writes CMD.h5 (provenance, datasets, summary), CMD.txt, summary.json and any
   figures under temporary names and renames them, summary.json last, only when
   all are complete; without an output folder it writes nothing.

It raises (:class:`inins.exceptions.InputError` for bad input) and never prints.
"""

import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import inins
from inins.commands import CommandSpec, load_command
from inins.exceptions import InputError
from inins.results import CommandResult, NullSink

if TYPE_CHECKING:  # pydantic is loaded only when a scenario is
    from inins.scenario.base import ScenarioModel


@dataclass(frozen=True)
class LoadedScenario:
    """A validated scenario with its text (after overrides) and where it came from."""

    model: "ScenarioModel"
    text: str
    source: str
    overrides: tuple


@dataclass(frozen=True)
class Execution:
    """One finished run: its summary (the content of summary.json), the files written
    (empty without an output folder), the command's result and any interrupt held
    during the final renames."""

    summary: dict
    paths: tuple
    result: CommandResult
    interrupted: int | None = None
    """A signal that arrived while the finished outputs were being renamed (held until
    they were all in place), else None."""


def load(spec: CommandSpec, scenario=None, overrides=()):
    """Import the command and load its scenario (the shipped default if ``scenario`` is
    None) with ``overrides`` (``key.path=value`` strings)."""
    from inins.io.resources import config_path
    from inins.scenario.base import load_scenario

    module = load_command(spec)
    default = config_path(spec.name, spec.default) if scenario is None else None
    model, text, source = load_scenario(module.SCENARIO_MODEL, scenario, list(overrides), default)
    return module, LoadedScenario(model, text, source, tuple(overrides))


def execute(
    spec: CommandSpec,
    scenario=None,
    overrides=(),
    seed=None,
    outdir=None,
    figures=False,
    progress=None,
    force=False,
) -> Execution:
    """Run command ``spec`` on a scenario file (or its shipped default).

    Parameters
    ----------
    spec : CommandSpec
    scenario : path, optional
    overrides : sequence of str
        ``key.path=value``, as ``--set``.
    seed : int, optional
        Wins over the scenario's seed; 0 <= seed <= :data:`MAX_SEED`.
    outdir : Path, optional
        Where to write the outputs; None writes nothing (a sweep point).
    figures : bool
        Also draw the command's figures (needs matplotlib).
    progress : callable, optional
        ``progress(done, total)``; with a ``phase(name)`` method it is also told the
        phase of the run (``simulate``, ``calibrate``, ``write``, ...).
    force : bool
        Run even if the estimated size exceeds the limits (:mod:`inins.commands.budget`).

    Raises
    ------
    InputError
        Bad input, found before the run where possible: the scenario, the seed, check
        names, a run too large for the machine, an unusable output folder.
    """
    from inins.commands.budget import check_budget
    from inins.scenario.base import resolve_seed

    check_path(scenario, "SCENARIO")
    check_seed(seed)
    module, loaded = load(spec, scenario, overrides)
    validate_check_names(module, loaded)
    makers = figure_makers(spec, module) if figures else {}
    seed_used = resolve_seed(seed, getattr(loaded.model, "seed", None))
    estimate = getattr(module, "estimate", None)
    size = estimate and estimate(loaded.model)
    if outdir is None:
        check_budget(size, None, force)
        result = run_located(module, loaded, seed_used, NullSink(), progress)
        return Execution(summarize(spec.name, loaded, seed_used, result, module), (), result)
    check_budget(size, None, force)  # samples and memory: before a folder is made
    outdir = prepare_outdir(outdir, spec.name)
    check_budget(size, outdir, force)
    return write_outputs(spec.name, module, loaded, seed_used, outdir, makers, progress)


MAX_SEED = 2**63 - 1
"""Largest seed (stored as a 64-bit integer in CMD.h5)."""


def check_seed(seed) -> None:
    """Bad input for a seed outside 0..:data:`MAX_SEED`."""
    if seed is not None and not 0 <= int(seed) <= MAX_SEED:
        raise InputError(f"seed {seed} is outside 0..{MAX_SEED} (2**63 - 1)", key="--seed")


def check_path(path, what) -> None:
    """Bad input for a path that is not valid UTF-8 (it could not be recorded)."""
    if path is None:
        return
    try:
        str(path).encode("utf-8")
    except UnicodeEncodeError:
        shown = str(path).encode("utf-8", "backslashreplace").decode("ascii", "replace")
        raise InputError(
            "the path is not valid UTF-8 (it could not be recorded in the outputs); rename it",
            source=shown,
            key=what,
        ) from None


def prepare_outdir(outdir, command=None) -> Path:
    """Create the output folder, make sure files can be created in it, and remove
    temporary files left there by runs that were killed; bad input if impossible, or
    if the folder holds the results of another command (``command``: this run's)."""
    from inins.exceptions import OutputError
    from inins.io.atomic import remove_stale_partials

    check_path(outdir, "--outdir")
    outdir = Path(outdir)
    if command is not None:
        check_owner(outdir, command)
    try:
        outdir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(
            f"cannot create the output directory ({exc.strerror})", source=str(outdir)
        ) from None
    probe = outdir / f".inins-probe-{os.getpid()}"
    try:
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise OutputError(
            f"cannot write in the output directory ({exc.strerror})", source=str(outdir)
        ) from None
    remove_stale_partials(outdir)
    return outdir


def folder_owner(outdir) -> tuple[str, str] | None:
    """``(command, evidence)`` of the results already in ``outdir`` (a file named after a
    command, or summary.json's command; ``sweep`` for a sweep folder), or None."""
    from inins.commands import COMMANDS

    outdir = Path(outdir)
    if not outdir.is_dir():
        return None
    for name in ("journal.jsonl", "sweep.csv", "sweep.h5"):
        if (outdir / name).exists():
            return "sweep", name
    summary = outdir / "summary.json"
    if summary.is_file():
        import json

        try:
            command = json.loads(summary.read_text(encoding="utf-8")).get("command")
        except (OSError, ValueError, AttributeError):
            command = None
        if isinstance(command, str) and command:
            return command, "summary.json"
    for spec in COMMANDS:
        if (outdir / f"{spec.name}.h5").exists():
            return spec.name, f"{spec.name}.h5"
    return None


def check_owner(outdir, command) -> None:
    """Refuse an output folder holding another command's results: a folder is one
    command's (the file contract: CMD.h5, CMD.txt, summary.json belong together)."""
    from inins.exceptions import OutputError

    owner = folder_owner(outdir)
    if owner is not None and owner[0] != command:
        other, evidence = owner
        raise OutputError(
            f"holds the results of inins {other} ({evidence}); they are not mixed with "
            f"{command}'s: write to another folder, e.g. -o {Path(outdir) / command}",
            source=str(outdir),
        )


def figure_makers(spec, module):
    """``{png name: function(result, path)}`` of a command; bad input if impossible."""
    makers = getattr(module, "FIGURES", None)
    if not makers:
        raise InputError(f"inins {spec.name} has no figures to plot", key="--plot")
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise InputError(
            "--plot needs matplotlib, which is not installed: pip install 'inins[plot]'",
            key="--plot",
        ) from None
    return makers


def summarize(command, loaded, seed, result, module=None):
    """The summary dict of a result: checks evaluated, verdict."""
    from inins.io.summary import build_summary

    checks = evaluate_checks(loaded, result, declared_names(module, loaded))
    built_in = getattr(module, "built_in_checks", None)
    if built_in is not None:  # the command's own verdicts, e.g. an alignment gone wrong
        from inins.scenario.checks import evaluate_checks as evaluate

        checks += evaluate(built_in(loaded.model, result.results), result.results, result.truth)
    return build_summary(
        command, inins.__version__, loaded.source, seed, result.results, result.truth, checks
    )


def write_outputs(command, module, loaded, seed, outdir, makers=None, progress=None):
    """Call ``module.run`` and write the three outputs (and any figures) atomically.

    A full disk at any point is one :class:`~inins.exceptions.OutputError` naming the
    device and file; nothing is left behind.
    """
    from inins.io.atomic import AtomicGroup
    from inins.io.diskspace import disk_full_error, is_disk_full

    makers = makers or {}
    files = output_files(module, loaded)
    names = (*makers, *files, f"{command}.h5", f"{command}.txt", "summary.json")
    # a folder holds one run's files: an earlier run's figures (or files) not written now
    # are removed
    stale = {*getattr(module, "FIGURES", {}), *getattr(module, "OPTIONAL_FILES", ())}
    group = AtomicGroup(outdir, names, stale=stale)
    current = [outdir / f"{command}.h5"]
    try:
        with group:
            summary, result = _write_all(
                command, module, loaded, seed, group, makers, progress, current
            )
    except (OSError, RuntimeError) as exc:
        if is_disk_full(exc):
            raise disk_full_error(current[0]) from None
        if isinstance(exc, PermissionError | IsADirectoryError):
            raise InputError(f"cannot write ({exc.strerror})", source=str(current[0])) from None
        raise
    paths = tuple(outdir / n for n in names if n in group.files)
    return Execution(summary, paths, result, group.interrupted)


def output_files(module, loaded):
    """The command's extra text files, ``{name: function(result) -> text}``: its ``FILES``,
    or ``FILES(scenario)`` where they depend on the scenario (an export it asks for);
    ``OPTIONAL_FILES`` names every file it may write (removed when not written)."""
    files = getattr(module, "FILES", {})
    return files(loaded.model) if callable(files) else files


def _write_all(command, module, loaded, seed, group, makers, progress, current):
    from inins.io.hdf5 import ResultsWriter
    from inins.io.provenance import make_provenance
    from inins.io.report import build_report
    from inins.io.summary import summary_text

    prov = make_provenance(command, loaded.text, loaded.source, seed, list(loaded.overrides))
    with ResultsWriter(group[f"{command}.h5"]) as h5:
        h5.set_attrs("", prov)
        with h5.sink(threaded=True) as sink:
            result = run_located(module, loaded, seed, sink, progress)
        if not isinstance(result, CommandResult):
            raise TypeError(f"run() returned {type(result).__name__}, expected a CommandResult")
        _phase(progress, "write")
        h5.write_result(result)
        summary = summarize(command, loaded, seed, result, module)
        h5.set_attrs("", {"summary_json": summary_text(summary)})
    notes = []
    for name, make in makers.items():
        current[0] = group[name].path
        reason = _draw(make, result, group[name].tmp, group[f"{command}.h5"].tmp)
        if reason is not None:  # not drawn: no file (nor an earlier one), the report says why
            group[name].discard()
            del group.files[name]
            group.stale.add(name)
            if reason:
                notes.append(f"figure {name} not drawn: {reason}")
    for name, text in output_files(module, loaded).items():
        current[0] = group[name].path
        group[name].tmp.write_text(text(result), encoding="utf-8")
    report = build_report(
        prov, result.report, (*result.warnings, *notes), summary["checks"], tuple(group.files)
    )
    current[0] = group[f"{command}.txt"].path
    group[f"{command}.txt"].tmp.write_text(report, encoding="utf-8")
    current[0] = group["summary.json"].path
    group["summary.json"].tmp.write_text(summary_text(summary), encoding="utf-8")
    current[0] = group.directory
    return summary, result


PHASES = {
    "simulate-table": "simulate",
    "import-log": "import",
    "calibrate-bias": "calibrate",
    "align-ett": "align",
}
"""Progress label of each command's main work (then ``write``)."""


def run_located(module, loaded, seed, sink, progress):
    """``module.run``; a bad-input error keyed by a scenario key path but not placed in a
    file (``steps[2]: ...``) is placed in the scenario file, at its line."""
    command = getattr(loaded.model, "__module__", "").rsplit(".", 1)[-1].replace("_", "-")
    _phase(progress, PHASES.get(command, "run"))
    try:
        return module.run(loaded.model, seed, sink=sink, progress=progress)
    except InputError as exc:
        if exc.source is None and exc.key:
            exc.source = loaded.source
            if not loaded.overrides:
                from inins.scenario.yaml_source import line_of, parse_yaml

                lines = parse_yaml(loaded.text, loaded.source)[1]
                exc.line = line_of(lines, _key_path(exc.key))
        raise


def _key_path(key: str) -> tuple:
    """``"steps[2].start_s"`` -> ``("steps", 2, "start_s")``."""
    import re

    return tuple(
        int(part) if part.isdigit() else part for part in re.split(r"[.\[\]]+", key) if part
    )


def _draw(make, result, path, data) -> str | None:
    """Call a figure function with the results file if it takes one (see
    :mod:`inins.commands.figures`); the reason if it declined to draw (nothing to
    show: :class:`~inins.commands.figures.Skipped`; an empty reason for a figure of
    another kind of run, :class:`~inins.commands.figures.NotThisRun`), else None."""
    import inspect

    from inins.commands.figures import NotThisRun, Skipped

    try:
        if len(inspect.signature(make).parameters) >= 3:
            make(result, path, data)
        else:
            make(result, path)
    except NotThisRun:
        return ""
    except Skipped as exc:
        return str(exc)
    return None


def _phase(progress, name) -> None:
    """Tell a progress display which phase the run is in (if it wants to know)."""
    phase = getattr(progress, "phase", None)
    if phase is not None:
        phase(name)


def declared_names(module, loaded):
    """``(results, truth)`` names the command declares for this scenario, or None.

    A command module declares them with ``declared_results(scenario) -> (results,
    truth)`` (each a set of names); checks are validated against them before the run.
    """
    declare = getattr(module, "declared_results", None)
    return None if declare is None else declare(loaded.model)


def validate_check_names(module, loaded) -> None:
    """Every name in the scenario's checks must be a declared result (or truth) name;
    checked before the run, located in the file or the ``--set`` item."""
    from inins.scenario.checks import validate_names

    names = declared_names(module, loaded)
    checks = getattr(loaded.model, "checks", [])
    if names is None or not checks:
        return
    try:
        validate_names(checks, *names)
    except InputError as exc:
        raise _locate_check_error(exc, loaded) from None


def evaluate_checks(loaded, result, names=None):
    """Evaluate the scenario's checks; locate a bad one in the file.

    ``names``: the declared ``(results, truth)``; a declared result this run did not
    produce makes its check fail ("not available") instead of being bad input.
    """
    from inins.scenario.checks import evaluate_checks as evaluate

    results = result.results
    if names is not None:
        results = {**dict.fromkeys(names[0]), **results}
    try:
        return evaluate(getattr(loaded.model, "checks", []), results, result.truth)
    except InputError as exc:
        raise _locate_check_error(exc, loaded) from None


def _locate_check_error(exc, loaded):
    """``exc`` (keyed ``checks[i]``) with the file and line, or the ``--set`` item."""
    from inins.scenario.yaml_source import line_of, parse_yaml

    exc.source = loaded.source
    if exc.key and exc.key.startswith("checks["):
        set_item = next(
            (o for o in loaded.overrides if o.split("=", 1)[0].strip().startswith("checks")),
            None,
        )
        if set_item is not None:
            exc.key = f"{exc.key} (from --set {set_item})"
        elif not loaded.overrides:
            index = int(exc.key[len("checks[") : -1])
            exc.line = line_of(parse_yaml(loaded.text, loaded.source)[1], ("checks", index))
    return exc
