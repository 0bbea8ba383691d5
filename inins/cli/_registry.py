"""The table of commands: name -> module, shipped default scenario, help text.

Only this table is read when the CLI starts; a command's module is imported
when the command runs (or ``inins schema`` asks for its model), so
``inins --help`` stays fast and a module may import numpy, numba, pydantic at
its top.
"""

import importlib
from dataclasses import dataclass

_OUTPUTS = (
    "Writes OUTDIR/{name}.h5 (results), OUTDIR/{name}.txt (report) and "
    "OUTDIR/summary.json. With no SCENARIO runs the shipped scenario "
    "configs/{name}/{default}.yaml. Exit codes: 0 done, 1 a check failed, "
    "2 bad input, 3 internal error."
)


@dataclass(frozen=True)
class CommandSpec:
    """One command of the registry.

    Attributes
    ----------
    name : str
        Command name, also the output file stem (``simulate-table``).
    module : str
        Import path of the command module (see :mod:`inins.cli`).
    help : str
        One-paragraph description (from spec §1).
    default : str
        Shipped scenario run when no SCENARIO is given:
        ``configs/<name>/<default>.yaml``.
    """

    name: str
    module: str
    help: str
    default: str = "default"

    def full_help(self) -> str:
        """Help text for ``inins NAME --help``."""
        return f"{self.help}\n\n" + _OUTPUTS.format(name=self.name, default=self.default)


COMMANDS = (
    CommandSpec(
        "simulate-table", "inins.cli.simulate_table",
        "An IMU on a 2- or 3-axis rate table running a motion program, with sensor "
        "errors and disturbances; writes truth and IMU increments.",
    ),
    CommandSpec(
        "import-log", "inins.cli.import_log",
        "Import a lab IMU log (CSV, HDF5 or PSINS text) into the table-data layout that "
        "calibrate-bias and align-ett read; reports a stationary check of every hold: "
        "attitude, Earth rate, implied latitude, gravity.",
    ),
    CommandSpec(
        "calibrate-bias", "inins.cli.calibrate_bias",
        "Gyro-bias calibration from table data (simulated or a real log): "
        "attitude-error, velocity-error (quadratic fit) and the disturbance-robust "
        "return-sequence method.",
    ),
    CommandSpec(
        "align-ett", "inins.cli.align_ett",
        "Azimuth of the IMU on the table from the pitch-90 deg / pitch-0 deg positions "
        "with accelerometers only (equivalent linear transformation), compared with "
        "gyrocompassing.",
    ),
    CommandSpec(
        "run-ekf", "inins.cli.run_ekf",
        "Tightly coupled INS/GPS EKF (17 or 26 states, feedforward or feedback) on a "
        "simulated flight (climbs, descents, repeated bank turns) or on recorded data.",
    ),
    CommandSpec(
        "observability", "inins.cli.observability",
        "Observability of an INS error model along a piecewise-constant manoeuvre: "
        "ranks, unobservable combinations, degree of observability.",
    ),
)
"""The five commands of spec §1 and import-log, in the order ``inins --help`` lists them."""


class CommandUnavailable(Exception):
    """The command cannot run in this version (placeholder or missing module)."""


def find_command(name: str, commands=COMMANDS) -> CommandSpec:
    """The spec of command ``name``.

    Raises
    ------
    CommandUnavailable
        No such command (the message lists the known ones).
    """
    for spec in commands:
        if spec.name == name:
            return spec
    known = ", ".join(s.name for s in commands)
    raise CommandUnavailable(f"unknown command {name!r} (commands: {known})")


def load_command(spec: CommandSpec):
    """Import a command's module and check it provides the interface.

    Returns
    -------
    module
        With ``SCENARIO_MODEL`` and ``run``.

    Raises
    ------
    CommandUnavailable
        The module is missing, or a placeholder (``SCENARIO_MODEL`` is None).
    """
    try:
        module = importlib.import_module(spec.module)
    except ModuleNotFoundError as exc:
        if exc.name != spec.module:
            raise
        raise CommandUnavailable(
            f"inins {spec.name}: not available in this installation "
            f"(module {spec.module} is missing)"
        ) from None
    if getattr(module, "SCENARIO_MODEL", None) is None or getattr(module, "run", None) is None:
        raise CommandUnavailable(f"inins {spec.name}: not implemented yet in this version")
    return module
