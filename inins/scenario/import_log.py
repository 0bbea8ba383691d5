"""Scenario of ``inins import-log``: a lab IMU log into the table-data layout (spec §3).

Paths
-----
``log.file`` is relative to the directory of the scenario file (an absolute
path is used as it is): the shipped ``configs/import-log/default.yaml`` reads
``../../data/rlg-static-excerpt.imu``, which resolves in a source checkout and
in an installed wheel alike (:data:`inins.scenario.base.ScenarioPath`).

Columns
-------
CSV: a header name (with ``log.csv.header: true``) or a 0-based column index.
HDF5: a 1-D dataset path, or ``path[j]`` for column j (0-based) of a 2-D
dataset; ``gyro``, ``accel`` and ``table_angles`` may also name one 2-D
dataset holding all their columns. PSINS: fixed (gx gy gz ax ay az), none given.

Axes
----
``body_axes`` lists, for body x, y, z in turn, the log axis and sign it is:
``[+y, +x, -z]`` means body x = log y, body y = log x, body z = -log z. That
maps the PSINS RLG's X-right, Y-forward, Z-up onto the forward-right-down body
frame, so roll, pitch and heading read as those of the forward axis. The log
frame is taken to be right-handed; the mapping must be a rotation.
"""

from typing import Annotated, Literal

import numpy as np
from pydantic import Field, model_validator

from inins.core.units import ARCSEC, DEG, DPH, DPS
from inins.scenario.base import InputFile, ScenarioModel, ScenarioPath
from inins.scenario.base import ScenarioSection as Section
from inins.scenario.types import NonNegFloat, PositiveFloat
from inins.scenario.validation import KeyPathError

GimbalName = Literal["yaw", "pitch", "roll"]
AxisSign = Literal["+x", "-x", "+y", "-y", "+z", "-z"]
ColumnRef = Annotated[int, Field(ge=0)] | str

GYRO_UNITS = {
    "count": ("increment", 1.0),
    "rad": ("increment", 1.0),
    "deg": ("increment", DEG),
    "arcsec": ("increment", ARCSEC),
    "rad/s": ("rate", 1.0),
    "deg/s": ("rate", DPS),
    "deg/h": ("rate", DPH),
}
"""Gyro unit -> (quantity it measures, SI factor)."""
ACCEL_UNITS = {
    "count": ("increment", 1.0),
    "m/s": ("increment", 1.0),
    "m/s^2": ("rate", 1.0),
    "g": ("rate", None),
    "mg": ("rate", None),
    "ug": ("rate", None),
}
"""Accelerometer unit -> (quantity, SI factor; None: a multiple of g, see ``g_mps2``)."""
G_MULTIPLE = {"g": 1.0, "mg": 1e-3, "ug": 1e-6}
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
ANGLE_UNITS = {"deg": DEG, "rad": 1.0}


class CsvOptions(Section):
    """How a CSV (delimited text) log is laid out."""

    delimiter: str = Field(
        ",",
        min_length=1,
        description="field separator, one character, or 'whitespace' for runs of blanks and tabs",
    )
    comment: str = Field(
        "#",
        description="lines starting with this text are skipped, and it "
        "ends the data of a line; '' for none",
    )
    header: bool = Field(
        True,
        description="the first line after skip_lines that is not "
        "blank or a comment holds the column names",
    )
    skip_lines: int = Field(0, ge=0, description="lines skipped at the top before anything")


class Columns(Section):
    """Which columns (CSV) or datasets (HDF5) hold what; see the module docstring."""

    time: ColumnRef | None = Field(
        None,
        description="time of each row (in log.time_unit); "
        "optional, then rows are 1/sample_rate_hz apart",
    )
    gyro: list[ColumnRef] | str = Field(
        description="gyro x, y, z of the log (3 columns), or one (n, 3) HDF5 dataset"
    )
    accel: list[ColumnRef] | str = Field(
        description="accelerometer x, y, z of the log (3 columns), or one (n, 3) HDF5 dataset"
    )
    table_angles: list[ColumnRef] | str | None = Field(
        None,
        description="encoder angle per gimbal, outer first (in table.angle_unit); "
        "without a step list the holds are found from them",
    )


class Log(Section):
    """The log file and how its rows are read."""

    file: ScenarioPath = Field(description="the log; relative to the scenario file's folder")
    format: Literal["csv", "hdf5", "psins"] = Field(
        description="csv: delimited text; hdf5: datasets; psins: PSINS SIMU text log "
        "(site, sample interval and pulse weights from its header)"
    )
    csv: CsvOptions = Field(default_factory=CsvOptions)
    columns: Columns | None = Field(None, description="column mapping (csv, hdf5); none for psins")
    time_unit: Literal["s", "ms", "us"] = Field("s", description="unit of the time column")
    time_marks: Literal["end", "start"] = Field(
        "end",
        description="a row's time marks the end (as for increments) or the start of "
        "its sample interval",
    )
    sample_rate_hz: PositiveFloat | None = Field(
        None,
        description="sample rate (Hz); default from the time column (median step of "
        "the first rows) or the PSINS header",
    )

    @model_validator(mode="after")
    def _columns(self):
        if self.format == "psins" and self.columns is not None:
            raise KeyPathError(("columns",), "a PSINS log has fixed columns; remove this key")
        if self.format != "psins" and self.columns is None:
            raise KeyPathError(
                ("columns",), f"a {self.format} log needs the column mapping (time, gyro, accel)"
            )
        if self.columns is not None:
            for name in ("gyro", "accel"):
                refs = getattr(self.columns, name)
                if isinstance(refs, list) and len(refs) != 3:
                    raise KeyPathError(
                        ("columns", name), f"give 3 columns (x, y, z), got {len(refs)}"
                    )
        if self.format == "csv" and self.columns is not None:
            for name in ("gyro", "accel", "table_angles"):
                if isinstance(getattr(self.columns, name), str):
                    raise KeyPathError(("columns", name), "give a list of columns")
        if self.format == "hdf5" and self.columns is not None:
            refs = [
                self.columns.time,
                self.columns.gyro,
                self.columns.accel,
                self.columns.table_angles,
            ]
            flat = [
                r
                for ref in refs
                if ref is not None
                for r in (ref if isinstance(ref, list) else [ref])
            ]
            if any(isinstance(r, int) for r in flat):
                raise KeyPathError(
                    ("columns",),
                    "HDF5 columns are dataset paths ('name' or 'name[j]'), not numbers",
                )
        return self

    def sample_interval(self):
        """Sample interval (s), or None when it comes from the data."""
        return None if self.sample_rate_hz is None else 1.0 / self.sample_rate_hz


class LogGyro(Section):
    """What the gyro columns hold."""

    quantity: Literal["increment", "rate"] = Field(
        "increment", description="angle increment per sample, or angular rate"
    )
    unit: Literal["count", "rad", "deg", "arcsec", "rad/s", "deg/s", "deg/h"] = Field(
        "count",
        description="count (pulses, with pulse_weight_arcsec), rad, deg, arcsec "
        "(increments); rad/s, deg/s, deg/h (rates)",
    )
    pulse_weight_arcsec: list[PositiveFloat] | None = Field(
        None,
        min_length=3,
        max_length=3,
        description="angle per pulse (arcsec), log axes "
        "x y z; PSINS: from the header unless given here",
    )

    @model_validator(mode="after")
    def _consistent(self):
        _check_unit(self, GYRO_UNITS, "pulse_weight_arcsec")
        return self


class LogAccel(Section):
    """What the accelerometer columns hold."""

    quantity: Literal["increment", "rate"] = Field(
        "increment", description="velocity increment per sample, or specific force"
    )
    unit: Literal["count", "m/s", "m/s^2", "g", "mg", "ug"] = Field(
        "count",
        description="count (pulses, with pulse_weight_ug_s), m/s (increments); "
        "m/s^2, g, mg, ug (specific force)",
    )
    pulse_weight_ug_s: list[PositiveFloat] | None = Field(
        None,
        min_length=3,
        max_length=3,
        description="velocity per pulse (ug*s), log axes "
        "x y z; PSINS: from the header unless given here",
    )
    g_mps2: PositiveFloat | None = Field(
        None,
        description="the g behind the units g, mg, ug and ug*s (m/s^2); default "
        "9.80665, PSINS: the g of its header",
    )

    @model_validator(mode="after")
    def _consistent(self):
        _check_unit(self, ACCEL_UNITS, "pulse_weight_ug_s")
        return self


def _check_unit(section, units, weight_key):
    quantity = units[section.unit][0]
    if quantity != section.quantity:
        fitting = [u for u, (q, _) in units.items() if q == section.quantity and u != "count"]
        raise KeyPathError(
            ("unit",),
            f"{section.unit} is a unit of a {quantity}; for "
            f"quantity {section.quantity} use one of {', '.join(fitting)}",
        )
    if section.unit != "count" and getattr(section, weight_key) is not None:
        raise KeyPathError((weight_key,), "pulse weights apply to unit count only")


class LogSite(Section):
    """Where the log was recorded; PSINS: each value from the header unless given."""

    lat_deg: float | None = Field(None, ge=-90, le=90, description="geodetic latitude (deg)")
    lon_deg: float | None = Field(None, ge=-180, le=360, description="longitude (deg)")
    height_m: float | None = Field(
        None, ge=-1000, le=1e5, description="height above the ellipsoid (m)"
    )


class LogTable(Section):
    """The rate table (none for an IMU standing on a bench)."""

    gimbals: list[GimbalName] = Field(
        [],
        max_length=3,
        description="gimbal axes, outer first: yaw (table z), pitch (y), roll (x); [] for none",
    )
    base_azimuth_deg: float = Field(
        0.0, description="azimuth of the table x axis at zero yaw, clockwise from north (deg)"
    )
    angle_unit: Literal["deg", "rad"] = Field("deg", description="unit of the table-angle columns")
    hold_tolerance_deg: PositiveFloat = Field(
        0.01,
        description="holds found from the encoder: every angle stays within this "
        "(deg) over a block",
    )
    hold_margin_s: NonNegFloat = Field(
        1.0, description="holds found from the encoder are shortened by this at each end (s)"
    )


class LogStep(Section):
    """One step of the motion, in the log's time base (the time column, the PSINS t0, or
    seconds from the first sample)."""

    kind: Literal["hold", "rotate", "spin"] = Field(description="step type")
    label: str = Field("", max_length=32, description="name of the position")
    start_s: float = Field(description="start time (s)")
    end_s: float = Field(description="end time (s)")
    angles_deg: list[float] = Field(
        [], description="gimbal angles at the end of the step, outer first (deg); one per gimbal"
    )
    axis: GimbalName | None = Field(
        None,
        description="gimbal that moves (rotate, spin); a "
        "rotate step may omit it when one angle changes",
    )


class CheckSettings(Section):
    """The stationary check of every hold (levelling, gyrocompass, Earth rate, gravity)."""

    min_hold_s: PositiveFloat = Field(
        10.0, description="holds shorter than this (s) are not checked"
    )
    block_s: PositiveFloat = Field(1.0, description="the check works on blocks of this length (s)")
    screen: bool = Field(True, description="leave out disturbed blocks (see the report)")
    std_ratio: PositiveFloat = Field(
        3.0,
        description="a block is disturbed when a gyro's "
        "sample spread in it exceeds this many times the "
        "hold's median spread",
    )
    rate_sigma: PositiveFloat = Field(
        6.0,
        description="a block is also disturbed when its "
        "mean rate is this many robust sigmas from the hold's "
        "median rate",
    )
    guard_s: NonNegFloat = Field(
        5.0, description="disturbed blocks are widened by this (s) on both sides"
    )


class ImportLogScenario(ScenarioModel):
    """Import a lab IMU log (CSV, HDF5 or PSINS text) into the table-data layout."""

    log: Log
    compensation: InputFile | None = Field(
        None,
        description="a compensation file (written by calibrate-imu) applied to the "
        "increments as they are formed; the output then stores float increments (SI), "
        "not pulse counts, and names the file in its provenance",
    )
    compensation_serial: str | None = Field(
        None,
        description="serial of the unit in the log: a compensation file made for another "
        "serial is refused",
    )
    gyro: LogGyro = Field(default_factory=LogGyro)
    accel: LogAccel = Field(default_factory=LogAccel)
    body_axes: list[AxisSign] = Field(
        ["+x", "+y", "+z"],
        min_length=3,
        max_length=3,
        description="log axis and sign of body x, y, z: [+y, +x, -z] maps X-right, "
        "Y-forward, Z-up onto forward-right-down",
    )
    site: LogSite = Field(default_factory=LogSite)
    table: LogTable = Field(default_factory=LogTable)
    steps: list[LogStep] = Field(
        [],
        description="motion steps; without them holds come "
        "from the table angles, or the whole log is one hold",
    )
    check: CheckSettings = Field(default_factory=CheckSettings)

    @model_validator(mode="after")
    def _cross_checks(self):
        if self.log.format == "psins":
            for name in ("gyro", "accel"):
                if getattr(self, name).unit != "count":
                    raise KeyPathError((name, "unit"), "a PSINS log holds pulse counts")
        elif self.log.columns.time is None and self.log.sample_rate_hz is None:
            raise KeyPathError(("log", "sample_rate_hz"), "required without a time column")
        if self.log.format != "psins":
            for name, key in (("gyro", "pulse_weight_arcsec"), ("accel", "pulse_weight_ug_s")):
                section = getattr(self, name)
                if section.unit == "count" and getattr(section, key) is None:
                    raise KeyPathError((name, key), "unit count needs the pulse weights")
            for key in ("lat_deg", "lon_deg", "height_m"):
                if getattr(self.site, key) is None:
                    raise KeyPathError(("site", key), "required for a csv or hdf5 log")
        mat = self.mat_bl()
        if mat is None:
            raise KeyPathError(("body_axes",), "name each log axis x, y, z once")
        if np.linalg.det(mat) < 0:
            raise KeyPathError(
                ("body_axes",),
                "the mapping is a mirror image; flip one sign to make the body frame right-handed",
            )
        self._check_steps()
        return self

    def _check_steps(self):
        angles = self.log.columns.table_angles if self.log.columns else None
        n = len(self.table.gimbals)
        if angles is not None and isinstance(angles, list) and len(angles) != n:
            raise KeyPathError(
                ("log", "columns", "table_angles"),
                f"needs {n} columns, one per gimbal (table.gimbals)",
            )
        if angles is not None and n == 0:
            raise KeyPathError(("table", "gimbals"), "name the gimbals of the angle columns")
        previous = None
        for i, step in enumerate(self.steps):
            if len(step.angles_deg) != n:
                raise KeyPathError(
                    ("steps", i, "angles_deg"), f"needs {n} angles, one per gimbal (table.gimbals)"
                )
            if step.kind != "hold" and n == 0:
                raise KeyPathError(
                    ("steps", i, "kind"), f"a {step.kind} step needs a table (table.gimbals)"
                )
            changed = (
                0
                if previous is None
                else sum(a != b for a, b in zip(previous.angles_deg, step.angles_deg, strict=True))
            )
            if step.kind == "rotate" and step.axis is None and changed != 1:
                raise KeyPathError(
                    ("steps", i, "axis"),
                    f"{changed} gimbal angles change from "
                    "the step before; name the gimbal that turns",
                )
            if step.end_s <= step.start_s:
                raise KeyPathError(("steps", i, "end_s"), "must be after start_s")
            if previous is not None and step.start_s < previous.end_s:
                raise KeyPathError(
                    ("steps", i, "start_s"), "steps must follow in time without overlap"
                )
            if step.axis is not None and step.axis not in self.table.gimbals:
                raise KeyPathError(("steps", i, "axis"), f"the table has no {step.axis} gimbal")
            if step.kind == "spin" and step.axis is None:
                raise KeyPathError(("steps", i, "axis"), "a spin step needs its gimbal")
            previous = step

    def mat_bl(self):
        """Signed permutation mapping log axes to body axes (``v_b = mat_bl @ v_log``)."""
        mat = np.zeros((3, 3))
        for i, item in enumerate(self.body_axes):
            mat[i, "xyz".index(item[1])] = 1.0 if item[0] == "+" else -1.0
        return mat if np.all(np.abs(mat).sum(axis=0) == 1) else None


def import_settings(scenario):
    """The import in SI (:class:`inins.io.logimport.LogImport`)."""
    from inins.core.records import Step, StepKind
    from inins.io.logimport import CsvFormat, LogImport, ScreeningOptions, Sensor

    g, a, t, log = scenario.gyro, scenario.accel, scenario.table, scenario.log
    cols = log.columns
    index = {name: k for k, name in enumerate(t.gimbals)}
    steps = None
    if scenario.steps:
        steps, before = [], None
        for s in scenario.steps:
            end = np.array(s.angles_deg) * DEG
            start = end if s.kind == "hold" or before is None else before
            axis = index[s.axis] if s.axis is not None else _moved(start, end)
            kind = StepKind(s.kind)
            axis = -1 if kind == StepKind.HOLD else axis
            # sample indices are resolved once the log is read (scenario_steps)
            steps.append(Step(kind, s.label, axis, s.start_s, s.end_s, 0, 0, start, end))
            before = end
    c, chk = log.csv, scenario.check
    return LogImport(
        path=log.file,
        format=log.format,
        csv=CsvFormat(
            None if c.delimiter == "whitespace" else c.delimiter, c.comment, c.skip_lines, c.header
        ),
        time=None if cols is None else cols.time,
        gyro_cols=None if cols is None else cols.gyro,
        accel_cols=None if cols is None else cols.accel,
        angle_cols=None if cols is None else cols.table_angles,
        time_scale=TIME_UNITS[log.time_unit],
        time_marks=log.time_marks,
        dt=log.sample_interval(),
        gyro=Sensor(
            g.quantity,
            GYRO_UNITS[g.unit][1],
            g.unit == "count",
            None if g.pulse_weight_arcsec is None else np.array(g.pulse_weight_arcsec) * ARCSEC,
        ),
        accel=Sensor(
            a.quantity,
            ACCEL_UNITS[a.unit][1] or G_MULTIPLE[a.unit],
            a.unit == "count",
            None if a.pulse_weight_ug_s is None else np.array(a.pulse_weight_ug_s) * 1e-6,
            per_g=a.unit in ("count", "g", "mg", "ug"),
        ),
        g_unit=a.g_mps2,
        mat_bl=scenario.mat_bl(),
        site=tuple(
            None if v is None else v * f
            for v, f in (
                (scenario.site.lat_deg, DEG),
                (scenario.site.lon_deg, DEG),
                (scenario.site.height_m, 1.0),
            )
        ),
        gimbals=tuple(t.gimbals),
        base_azimuth=t.base_azimuth_deg * DEG,
        angle_scale=ANGLE_UNITS[t.angle_unit],
        hold_tolerance=t.hold_tolerance_deg * DEG,
        hold_margin=t.hold_margin_s,
        steps=None if steps is None else tuple(steps),
        check=ScreeningOptions(
            chk.block_s, chk.min_hold_s, chk.screen, chk.std_ratio, chk.rate_sigma, chk.guard_s
        ),
    )


def _moved(start, end):
    """Index of the gimbal whose angle changes most (-1 without gimbals)."""
    return int(np.argmax(np.abs(end - start))) if len(end) else -1
