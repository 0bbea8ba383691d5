"""One module per command: the plain function behind each ``inins CMD``.

A command module ``inins/commands/<name_with_underscores>.py`` provides

``SCENARIO_MODEL``
    The scenario's pydantic model (:mod:`inins.scenario`).
``run(scenario, seed, *, sink=None, progress=None) -> CommandResult``
    Runs the method packages on the validated scenario and builds the command's
    datasets, report and summary numbers from their typed outcome. ``sink`` (a
    :class:`inins.results.SeriesSink`) receives series too long for memory;
    ``progress(done, total)`` is called on long work. It raises
    :class:`inins.exceptions.InputError` for bad input and never prints or exits.
``FIGURES`` (optional)
    ``{png name: function(result, path)}`` drawn by ``--plot``.

:func:`inins.commands.execute.execute` runs a command end to end (scenario file,
overrides, seed, atomic outputs, checks); the CLI and the sweep runner both call
it. This module holds only the table of commands, so importing it is cheap.
"""

import importlib
from dataclasses import dataclass

from inins.exceptions import InputError

_OUTPUTS = (
    "Writes OUTDIR/{name}.h5 (results), OUTDIR/{name}.txt (report) and "
    "OUTDIR/summary.json. With no SCENARIO runs the shipped scenario "
    "configs/{name}/{default}.yaml. Exit codes: 0 done, 1 a check failed, "
    "2 bad input (or an output folder that cannot take the results, or a run too large: "
    "see --force), 3 internal error, 130 interrupted."
)


@dataclass(frozen=True)
class CommandSpec:
    """One command of the table.

    Attributes
    ----------
    name : str
        Command name, also the output file stem (``simulate-table``).
    help : str
        One-paragraph description (from spec §1).
    default : str
        Shipped scenario run when no SCENARIO is given: ``configs/<name>/<default>.yaml``.
    available : bool
        False for a command listed but not in this version.
    module : str, optional
        Import path of the command module; default ``inins.commands.<name>``.
    """

    name: str
    help: str
    default: str = "default"
    available: bool = True
    module: str | None = None

    @property
    def module_name(self) -> str:
        """Import path of the command module."""
        return self.module or f"inins.commands.{self.name.replace('-', '_')}"

    def full_help(self) -> str:
        """Help text for ``inins NAME --help``."""
        if not self.available:
            return (
                f"{self.help}\n\nNot yet available in this version: running it exits with code 4."
            )
        return f"{self.help}\n\n" + _OUTPUTS.format(name=self.name, default=self.default)


COMMANDS = (
    CommandSpec(
        "simulate-table",
        "An IMU on a 2- or 3-axis rate table running a motion program, with sensor "
        "errors and disturbances; writes truth and IMU increments.",
    ),
    CommandSpec(
        "import-log",
        "Import a lab IMU log (CSV, HDF5 or PSINS text) into the table-data layout that "
        "calibrate-bias and align-ett read; reports a stationary check of every hold: "
        "attitude, Earth rate, implied latitude, gravity.",
    ),
    CommandSpec(
        "import-flight",
        "Import a GNSS recording (RINEX observation and navigation files, or the PSINS "
        "tightly coupled file with its IMU) into the recorded-flight layout that run-ekf "
        "reads; reports a single-point-positioning check of every epoch.",
    ),
    CommandSpec(
        "calibrate-bias",
        "Gyro-bias calibration from table data (simulated or a real log): "
        "attitude-error, velocity-error (quadratic fit) and the disturbance-robust "
        "return-sequence method.",
    ),
    CommandSpec(
        "align-ett",
        "Azimuth of the IMU on the table from the pitch-90 deg / pitch-0 deg positions "
        "with accelerometers only (equivalent linear transformation), compared with "
        "gyrocompassing.",
    ),
    CommandSpec(
        "run-ekf",
        "Tightly coupled INS/GPS EKF (17 or 26 states, feedforward or feedback) on a "
        "simulated flight (climbs, descents, repeated bank turns) or on recorded data. "
        "With a post: section, a loosely coupled post-processor of a recorded drive: an "
        "IMU log and a GNSS solution file (RTKLIB .pos, CSV, .mat), RTS smoother, vehicle "
        "aiding, outage scoring.",
    ),
    CommandSpec(
        "observability",
        "Observability of an INS error model along a piecewise-constant manoeuvre: "
        "ranks, unobservable combinations, degree of observability.",
    ),
    CommandSpec(
        "noise",
        "Noise of an IMU at rest (any import-log format, a table-data file or a simulated "
        "hold): overlapping Allan deviation with confidence intervals, the IEEE 952 noise "
        "terms fitted with intervals, and the sensor error-model blocks for simulate-table, "
        "run-ekf and Kalibr.",
    ),
    CommandSpec(
        "calibrate-imu",
        "Calibration of every error term of both triads (biases, scale factors, "
        "misalignments, g-sensitivity): multi-position and rate tests on a table, or "
        "table-free; the schedule checked by a planner first; compensation file and "
        "calibration certificate.",
    ),
)
"""The five commands of spec §1 and import-log, in the order ``inins --help`` lists them."""


class CommandUnavailable(Exception):
    """The command cannot run in this version (not available, or unknown)."""


def find_command(name: str, commands=COMMANDS) -> CommandSpec:
    """The spec of command ``name``; :class:`~inins.exceptions.InputError` if unknown."""
    for spec in commands:
        if spec.name == name:
            return spec
    known = ", ".join(s.name for s in commands)
    raise InputError(f"unknown command {name!r} (commands: {known})")


def load_command(spec: CommandSpec):
    """Import a command's module (``SCENARIO_MODEL``, ``run``, optional ``FIGURES``).

    Raises
    ------
    CommandUnavailable
        The command is not available in this version.
    """
    if not spec.available:
        raise CommandUnavailable(f"inins {spec.name}: not yet available in this version")
    return importlib.import_module(spec.module_name)
