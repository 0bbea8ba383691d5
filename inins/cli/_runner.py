"""The shared runner: scenario -> plain function -> CMD.h5 + CMD.txt + summary.json.

Every command goes through :func:`run_command`, which

1. imports the command module (:func:`inins.cli._registry.load_command`);
2. loads the scenario (the file, or the shipped default) with its ``--set``
   overrides and validates it;
3. picks the seed: ``--seed`` > the scenario's ``seed`` >
   :data:`inins.io.scenario.DEFAULT_SEED` (0); the seed used is recorded;
4. calls ``run(model, seed)``, or ``run(model, seed, sink)`` if the function
   has a ``sink`` parameter (the sink streams into CMD.h5 on a writer thread);
5. writes CMD.h5 (provenance, datasets, summary), CMD.txt and summary.json
   under temporary names and renames them, summary.json last, only when all
   three are complete;
6. prints a short summary and returns the exit code.

Exit codes: 0 done, 1 a check failed, 2 bad input (:class:`InputError`, and
pydantic or YAML errors that slip through), 3 internal error (a bug), 130
interrupted. Messages are one line (plus listed extra problems) on stderr;
tracebacks only with ``--debug``.
"""

import inspect
import sys
import time
import traceback
from pathlib import Path
from typing import Annotated

import typer

from inins.cli._registry import CommandUnavailable, load_command
from inins.exceptions import InputError

EXIT_OK, EXIT_CHECK_FAILED, EXIT_BAD_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED = 0, 1, 2, 3, 130
DEFAULT_OUTDIR = Path("out")


def make_command(spec):
    """The Typer command function of a registered command."""

    def command(
        scenario: Annotated[Path | None, typer.Argument(
            metavar="SCENARIO.yaml", show_default=False,
            help="Scenario file; without it the shipped default scenario runs.")] = None,
        outdir: Annotated[Path, typer.Option(
            "--outdir", "-o", help="Output directory (created if missing).")] = DEFAULT_OUTDIR,
        overrides: Annotated[list[str] | None, typer.Option(
            "--set", metavar="KEY.PATH=VALUE", show_default=False,
            help="Override a scenario key (repeatable), e.g. --set imu.gyro.bias_dph=[1,0,0] "
            "or --set motion.3.duration_s=60. The value is YAML.")] = None,
        seed: Annotated[int | None, typer.Option(
            "--seed", min=0, show_default=False,
            help="Random seed; wins over the scenario's seed (default 0).")] = None,
        debug: Annotated[bool, typer.Option(
            "--debug", help="Show the traceback of an error.")] = False,
        plot: Annotated[bool, typer.Option(
            "--plot", help="Also write PNG figures (needs the plot extra: matplotlib).")
        ] = False,
    ) -> None:
        raise typer.Exit(run_command(spec, scenario, outdir, overrides or [], seed, debug,
                                     plot))

    command.__doc__ = spec.full_help()
    command.__name__ = spec.name.replace("-", "_")
    return command


def run_command(spec, scenario, outdir, overrides, seed, debug=False, plot=False) -> int:
    """Run one command end to end; return the exit code (never raises)."""
    return guarded(f"inins {spec.name}", debug,
                   lambda: _run(spec, scenario, Path(outdir), list(overrides), seed, plot))


def guarded(label: str, debug: bool, body) -> int:
    """Call ``body()`` and turn every exception into a message and exit code."""
    try:
        return body()
    except KeyboardInterrupt:
        echo_err(f"{label}: interrupted; no output written (earlier results are untouched)")
        return EXIT_INTERRUPTED
    except CommandUnavailable as exc:
        echo_err(str(exc))
        return EXIT_BAD_INPUT
    except Exception as exc:
        if debug:
            traceback.print_exception(exc, file=sys.stderr)
        message = input_message(exc)
        if message is not None:
            echo_err(f"{label}: error: {message}")
            return EXIT_BAD_INPUT
        hint = "" if debug else " (run with --debug for the traceback)"
        echo_err(f"{label}: internal error: {type(exc).__name__}: {exc}{hint}")
        return EXIT_INTERNAL


def input_message(exc) -> str | None:
    """The message of a bad-input exception, or None if ``exc`` is something else."""
    if isinstance(exc, InputError):
        return str(exc)
    pydantic = sys.modules.get("pydantic")
    if pydantic is not None and isinstance(exc, pydantic.ValidationError):
        errors = exc.errors()
        first = errors[0]
        where = ".".join(str(p) for p in first["loc"]) or exc.title
        more = f" (and {len(errors) - 1} more problems)" if len(errors) > 1 else ""
        return f"{where}: {first['msg']}{more}"
    yaml = sys.modules.get("yaml")
    if yaml is not None and isinstance(exc, yaml.YAMLError):
        return f"invalid YAML: {' '.join(str(exc).split())}"
    return None


def echo_err(message: str) -> None:
    """One plain message on stderr (no markup, no wrapping)."""
    typer.echo(message, err=True)


def _run(spec, scenario, outdir, overrides, seed, plot=False) -> int:
    from inins.cli._display import print_outcome
    from inins.io.resources import config_path
    from inins.io.scenario import load_scenario, resolve_seed

    module = load_command(spec)
    plots = _plot_makers(spec, module) if plot else {}
    default = config_path(spec.name, spec.default) if scenario is None else None
    model, text, source = load_scenario(module.SCENARIO_MODEL, scenario, overrides, default)
    seed_used = resolve_seed(seed, getattr(model, "seed", None))
    outdir = _prepare_outdir(outdir)
    start = time.perf_counter()
    summary, paths = write_outputs(
        spec.name, module.run, model, seed_used, outdir, text, source, overrides, plots
    )
    print_outcome(summary, paths, time.perf_counter() - start)
    return EXIT_OK if summary["passed"] else EXIT_CHECK_FAILED


def _prepare_outdir(outdir: Path) -> Path:
    try:
        outdir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create the output directory ({exc.strerror})",
                         source=str(outdir)) from None
    return outdir


def _plot_makers(spec, module):
    """``{png name: function(result, path)}`` of a command; bad input if impossible."""
    makers = getattr(module, "PLOTS", None)
    if not makers:
        raise InputError(f"inins {spec.name} has no figures to plot", key="--plot")
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise InputError("--plot needs matplotlib, which is not installed: "
                         "pip install 'inins[plot]'", key="--plot") from None
    return makers


def write_outputs(command, run, model, seed, outdir, text, source, overrides, plots=None):
    """Call ``run`` and write the three outputs (and any plots) atomically.

    Returns
    -------
    summary : dict
    paths : list of Path
        CMD.h5, CMD.txt, summary.json.
    """
    import inins
    from inins.io.atomic import AtomicGroup
    from inins.io.hdf5 import ResultsWriter
    from inins.io.provenance import make_provenance
    from inins.io.report import build_report
    from inins.io.summary import build_summary, summary_text

    prov = make_provenance(command, text, source, seed, overrides)
    plots = plots or {}
    names = (*plots, f"{command}.h5", f"{command}.txt", "summary.json")
    with AtomicGroup(outdir, names) as group:
        with ResultsWriter(group[f"{command}.h5"]) as h5:
            h5.set_attrs("", prov)
            result = _call(run, model, seed, h5)
            h5.write_result(result)
            checks = _checks(model, result, text, source, overrides)
            summary = build_summary(command, inins.__version__, source, seed,
                                    result.results, result.truth, checks)
            h5.set_attrs("", {"summary_json": summary_text(summary)})
        for name, make in plots.items():
            make(result, group[name].tmp)
        report = build_report(prov, result.report, result.warnings, checks)
        group[f"{command}.txt"].tmp.write_text(report, encoding="utf-8")
        group["summary.json"].tmp.write_text(summary_text(summary), encoding="utf-8")
    return summary, [outdir / n for n in names]


def _call(run, model, seed, h5):
    """Call the command's plain function, with a streaming sink if it takes one and a
    progress callback (``progress(done, total)``) if it takes one."""
    from inins.cli._display import ProgressBar
    from inins.results import CommandResult

    params = inspect.signature(run).parameters
    with ProgressBar("running") as bar:
        extra = {"progress": bar} if "progress" in params else {}
        if "sink" in params:
            with h5.sink(threaded=True) as sink:
                result = run(model, seed, sink=sink, **extra)
        else:
            result = run(model, seed, **extra)
    if not isinstance(result, CommandResult):
        raise TypeError(f"run() returned {type(result).__name__}, expected a CommandResult")
    return result


def _checks(model, result, text, source, overrides):
    """Evaluate the scenario's checks; locate a bad one in the file."""
    from inins.io.checks import evaluate_checks
    from inins.io.yaml_source import line_of, parse_yaml

    try:
        return evaluate_checks(getattr(model, "checks", []), result.results, result.truth)
    except InputError as exc:
        exc.source = source
        if not overrides and exc.key and exc.key.startswith("checks["):
            index = int(exc.key[len("checks["):-1])
            exc.line = line_of(parse_yaml(text, source)[1], ("checks", index))
        raise
