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

from dataclasses import dataclass
from pathlib import Path

import inins
from inins.commands import CommandSpec, load_command
from inins.exceptions import InputError
from inins.results import CommandResult, NullSink


@dataclass(frozen=True)
class LoadedScenario:
    """A validated scenario with its text (after overrides) and where it came from."""

    model: object
    text: str
    source: str
    overrides: tuple


@dataclass(frozen=True)
class Execution:
    """One finished run: its summary (the content of summary.json), the files written
    (empty without an output folder) and the command's result."""

    summary: dict
    paths: tuple
    result: CommandResult


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
) -> Execution:
    """Run command ``spec`` on a scenario file (or its shipped default).

    Parameters
    ----------
    spec : CommandSpec
    scenario : path, optional
    overrides : sequence of str
        ``key.path=value``, as ``--set``.
    seed : int, optional
        Wins over the scenario's seed.
    outdir : Path, optional
        Where to write the outputs; None writes nothing (a sweep point).
    figures : bool
        Also draw the command's figures (needs matplotlib).
    progress : callable, optional
        ``progress(done, total)``.
    """
    from inins.scenario.base import resolve_seed

    module, loaded = load(spec, scenario, overrides)
    makers = figure_makers(spec, module) if figures else {}
    seed_used = resolve_seed(seed, getattr(loaded.model, "seed", None))
    if outdir is None:
        result = module.run(loaded.model, seed_used, sink=NullSink(), progress=progress)
        return Execution(summarize(spec.name, loaded, seed_used, result), (), result)
    return write_outputs(
        spec.name, module.run, loaded, seed_used, prepare_outdir(outdir), makers, progress
    )


def prepare_outdir(outdir) -> Path:
    """Create the output folder; bad input if impossible."""
    outdir = Path(outdir)
    try:
        outdir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(
            f"cannot create the output directory ({exc.strerror})", source=str(outdir)
        ) from None
    return outdir


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


def summarize(command, loaded, seed, result):
    """The summary dict of a result: checks evaluated, verdict."""
    from inins.io.summary import build_summary

    checks = evaluate_checks(loaded, result)
    return build_summary(
        command, inins.__version__, loaded.source, seed, result.results, result.truth, checks
    )


def write_outputs(command, run, loaded, seed, outdir, makers=None, progress=None):
    """Call ``run`` and write the three outputs (and any figures) atomically."""
    from inins.io.atomic import AtomicGroup
    from inins.io.hdf5 import ResultsWriter
    from inins.io.provenance import make_provenance
    from inins.io.report import build_report
    from inins.io.summary import summary_text

    prov = make_provenance(command, loaded.text, loaded.source, seed, list(loaded.overrides))
    makers = makers or {}
    names = (*makers, f"{command}.h5", f"{command}.txt", "summary.json")
    with AtomicGroup(outdir, names) as group:
        with ResultsWriter(group[f"{command}.h5"]) as h5:
            h5.set_attrs("", prov)
            with h5.sink(threaded=True) as sink:
                result = run(loaded.model, seed, sink=sink, progress=progress)
            if not isinstance(result, CommandResult):
                raise TypeError(f"run() returned {type(result).__name__}, expected a CommandResult")
            h5.write_result(result)
            summary = summarize(command, loaded, seed, result)
            h5.set_attrs("", {"summary_json": summary_text(summary)})
        for name, make in makers.items():
            make(result, group[name].tmp)
        report = build_report(prov, result.report, result.warnings, summary["checks"])
        group[f"{command}.txt"].tmp.write_text(report, encoding="utf-8")
        group["summary.json"].tmp.write_text(summary_text(summary), encoding="utf-8")
    return Execution(summary, tuple(outdir / n for n in names), result)


def evaluate_checks(loaded, result):
    """Evaluate the scenario's checks; locate a bad one in the file."""
    from inins.scenario.checks import evaluate_checks as evaluate
    from inins.scenario.yaml_source import line_of, parse_yaml

    try:
        return evaluate(getattr(loaded.model, "checks", []), result.results, result.truth)
    except InputError as exc:
        exc.source = loaded.source
        if not loaded.overrides and exc.key and exc.key.startswith("checks["):
            index = int(exc.key[len("checks[") : -1])
            exc.line = line_of(parse_yaml(loaded.text, loaded.source)[1], ("checks", index))
        raise
