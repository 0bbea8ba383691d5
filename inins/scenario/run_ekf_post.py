"""Scenario section ``post:`` of ``inins run-ekf``: post-processing a drive.

Loosely coupled filter on a GNSS solution file (RTKLIB ``.pos`` or a CSV with named
columns) and an IMU log (CSV with rates), the IMU-GNSS time mapping, RTS smoothing,
the outage protocol scored against a reference (the RTK-fixed epochs of the
solution file). Lab units at this edge (deg, deg/h, ug, ppm); SI inside.
"""

from typing import Annotated, Literal

from pydantic import Field, PositiveInt, model_validator

from inins.scenario.base import InputFile
from inins.scenario.base import ScenarioSection as Section
from inins.scenario.run_ekf_reference import ReferenceTrajectory
from inins.scenario.types import LeverArm, MountingAngles, NonNegFloat, PositiveFloat, Sigma
from inins.scenario.validation import KeyPathError

AxisName = Literal["x", "-x", "y", "-y", "z", "-z"]
Column = Annotated[int, Field(ge=0)]
"""A 0-based column index."""
ColumnRef = Column | Annotated[str, Field(min_length=1)]
"""A 0-based column index, or a CSV header row's column name."""
_AXIS_MATRIX = {"x": (0, 1), "-x": (0, -1), "y": (1, 1), "-y": (1, -1), "z": (2, 1), "-z": (2, -1)}


def _axes_problem(axes):
    """Why an axis map is no rotation of the IMU axes, or None."""
    index = [_AXIS_MATRIX[a][0] for a in axes]
    if sorted(index) != [0, 1, 2]:
        return f"{list(axes)} do not name x, y and z once each"
    sign = [_AXIS_MATRIX[a][1] for a in axes]
    # the determinant of a signed permutation: the signs times the permutation's parity
    parity = 1 if index in ([0, 1, 2], [1, 2, 0], [2, 0, 1]) else -1
    if parity * sign[0] * sign[1] * sign[2] < 0:
        return (
            f"{list(axes)} is a mirror image (left-handed): body x, y, z must be a rotation "
            "of the IMU axes (change the sign of one axis)"
        )
    return None


class ImuLog(Section):
    """IMU log: a CSV of rates, one sample a row (columns by 0-based index, or by name
    from the header row the file then starts with), or a 2-D array of increments in a
    .mat file."""

    file: InputFile = Field(description="IMU file (.csv, .csv.gz or .mat), relative to this file")
    format: Literal["csv", "mat", "recorded"] = Field(
        "csv",
        description="csv: rates; mat: increments (rad, m/s) over each interval ending at "
        "its time tag, in the array mat_variable; recorded: the IMU of a recorded-solution "
        "file (import-flight format: solution; columns, units and axes already applied)",
    )
    mat_variable: str = Field("mimu", description="mat: the array's name")
    accel_columns: tuple[ColumnRef, ColumnRef, ColumnRef] = Field(
        (0, 1, 2),
        description="columns of the accelerometer x, y, z: 0-based indices, or csv header "
        "names (column)",
    )
    gyro_columns: tuple[ColumnRef, ColumnRef, ColumnRef] = Field(
        (3, 4, 5), description="columns of the gyro x, y, z: 0-based or header names (column)"
    )
    time_column: ColumnRef = Field(
        6, description="column of the sample time: 0-based or a header name (column)"
    )
    time_scale_s: PositiveFloat = Field(
        1e-3, description="seconds per unit of the time column (s); 1e-3 for a millisecond tick"
    )
    accel_unit: Literal["g", "mps2"] = Field(
        "g", description="accelerometer unit (g: 9.80665 m/s^2)"
    )
    gyro_unit: Literal["dps", "rads"] = Field("dps", description="gyro unit: deg/s or rad/s")
    axes: tuple[AxisName, AxisName, AxisName] = Field(
        ("x", "y", "z"),
        description="IMU axis giving body x (forward), y (right), z (down), e.g. [-x, y, -z]",
    )
    rate_hz: PositiveFloat = Field(
        100.0, le=2000.0, description="uniform rate the rates are resampled to (Hz)"
    )
    odometer_column: ColumnRef | None = Field(
        None,
        description="column of a wheel-odometer forward speed, if any: 0-based or a header "
        "name (column)",
    )
    odometer_scale_mps: PositiveFloat = Field(
        1.0, description="speed per unit of the odometer column (m/s)"
    )

    @model_validator(mode="after")
    def _columns(self):
        problem = _axes_problem(self.axes)
        if problem:
            raise KeyPathError(("axes",), problem)
        if self.format == "mat":
            for key in ("accel_columns", "gyro_columns", "time_column"):
                value = getattr(self, key)
                if any(
                    isinstance(c, str) for c in (value if isinstance(value, tuple) else [value])
                ):
                    raise KeyPathError((key,), "mat: 0-based column indices, no names")
        used = {}
        named = [("accel_columns", c) for c in self.accel_columns]
        named += [("gyro_columns", c) for c in self.gyro_columns]
        named.append(("time_column", self.time_column))
        if self.odometer_column is not None and self.format == "csv":
            named.append(("odometer_column", self.odometer_column))
        for key, column in named:
            if column in used:
                raise KeyPathError(
                    (key,), f"column {column} is given twice (also in {used[column]})"
                )
            used[column] = key
        return self


class GnssFile(Section):
    """GNSS solutions (or a reference INS's): RTKLIB .pos, a CSV with named columns, or
    a 2-D array in a .mat file (columns by 0-based index)."""

    file: InputFile = Field(description="solution file (.pos, .csv, .mat, optionally .gz)")
    format: Literal["rtklib", "csv", "mat", "recorded"] = Field(
        "rtklib",
        description="file format; recorded: the solution epochs of a recorded-solution file "
        "(import-flight format: solution)",
    )
    mat_variable: str = Field("", description="mat: the array's name")
    sigma_m: PositiveFloat | None = Field(
        None, description="mat: position 1-sigma of every epoch (m), without sigma columns"
    )
    sigma_vel_mps: PositiveFloat | None = Field(
        None, description="mat: velocity 1-sigma of every epoch (m/s)"
    )
    attitude_columns: dict[Literal["roll", "pitch", "yaw"], int] | None = Field(
        None, description="mat: 0-based columns of a reference attitude (rad), for scoring"
    )
    yaw_sign: Literal[1, -1] = Field(
        1, description="heading = yaw_sign * yaw (PSINS yaw is positive west: -1)"
    )
    columns: dict[str, str | int] = Field(
        default_factory=dict,
        description="csv: role -> column name (mat: 0-based index); roles time, lat, lon, "
        "height (or x, y, z ECEF m), sigma_n, sigma_e, sigma_d (m), vel_n, vel_e, vel_d "
        "or vel_u (m/s), sigma_vn, sigma_ve, sigma_vd, q",
    )
    angle_unit: Literal["deg", "rad"] = Field("deg", description="csv: unit of lat and lon")
    time_scale_s: PositiveFloat = Field(
        1.0, description="csv: seconds per unit of the time column (s)"
    )
    time_system: Literal["gps", "utc", "unix"] = Field(
        "gps",
        description="csv, mat: what the time column counts: gps seconds since 1980-01-06 "
        "(GPS time); utc seconds on that grid; unix: UTC seconds since 1970-01-01 (UTC: the "
        "leap seconds of the date added; a .pos file says UTC in its header) (s)",
    )
    q_flags: list[int] = Field(
        [1, 2], min_length=1, description="quality flags used (RTKLIB 1 fix, 2 float, 5 single)"
    )
    sigma_scale: dict[int, PositiveFloat] = Field(
        default_factory=dict,
        description="sigma multiplier per quality flag (1): e.g. {2: 3} inflates float epochs",
    )
    use_velocity: bool = Field(
        False, description="update with the file's velocities too (where it has them)"
    )

    @model_validator(mode="after")
    def _roles(self):
        from inins.io.solution_checks import role_problem

        if self.format in ("csv", "mat"):
            problem = role_problem(self.columns, self.format == "csv" or self.sigma_m is None)
            if problem:
                raise KeyPathError(("columns", problem[0]), problem[1])
        if self.format == "mat":
            for role, column in self.columns.items():
                if not isinstance(column, int) or column < 0:
                    raise KeyPathError(("columns", role), "mat: a 0-based column index (>= 0)")
            if not self.mat_variable:
                raise KeyPathError(("mat_variable",), "mat: the name of the array is required")
        elif self.format == "csv":
            for role, column in self.columns.items():
                if not isinstance(column, str):
                    raise KeyPathError(("columns", role), "csv: a column name of the header")
        elif self.columns:
            raise KeyPathError(("columns",), f"format {self.format}: no columns to map")
        if self.time_system != "gps" and self.format not in ("csv", "mat"):
            raise KeyPathError(
                ("time_system",), f"format {self.format}: its time system is in the file"
            )
        if self.attitude_columns is not None:
            if self.format != "mat":
                raise KeyPathError(("attitude_columns",), "only a .mat array has them")
            missing = {"roll", "pitch", "yaw"} - set(self.attitude_columns)
            if missing:
                raise KeyPathError(
                    ("attitude_columns",), f"roll, pitch and yaw needed: {sorted(missing)} missing"
                )
            if min(self.attitude_columns.values()) < 0:
                raise KeyPathError(("attitude_columns",), "0-based column indices (>= 0)")
        return self


class TimeMapping(Section):
    """IMU time -> GNSS time: a constant offset fitted to the turn-rate lag (a rate only
    when the data demand it), then a residual offset state."""

    fit: Literal["none", "turn_rate"] = Field(
        "turn_rate",
        description="turn_rate: lag of the IMU yaw rate against the GNSS course rate in "
        "windows, the mapping fitted through them (model); none: IMU time is GNSS time "
        "minus the first GNSS epoch plus offset_s",
    )
    model: Literal["auto", "constant", "line", "piecewise"] = Field(
        "auto",
        description="turn_rate: auto: a constant offset unless the line's clock rate "
        "passes its t test at rate_false_alarm; constant; line (offset and rate); "
        "piecewise: the window lags interpolated (outlier windows dropped) for a mapping "
        "that steps",
    )
    rate_false_alarm: float = Field(
        0.01,
        gt=0.0,
        lt=0.5,
        description="model auto: probability that a zero clock rate is taken for one "
        "(two-sided t test of the fitted rate) (1)",
    )
    offset_s: float = Field(
        0.0, description="fit none: GNSS time (from the first epoch) of IMU time 0 (s)"
    )
    window_s: PositiveFloat = Field(60.0, ge=10.0, description="turn_rate: window length (s)")
    search_s: PositiveFloat = Field(10.0, le=600.0, description="turn_rate: lags searched, +-(s)")
    state: bool = Field(True, description="estimate a residual constant offset as a state")
    state_sigma_s: PositiveFloat = Field(0.05, le=10.0, description="its initial 1-sigma (s)")
    state_walk_s_rts: NonNegFloat = Field(
        1e-3,
        lt=1.0,
        description="its random-walk density: how far it may wander, 1e-3 is 22 ms over "
        "500 s (on the lc-drive the estimates of the four scenarios then spread by 6 ms "
        "std against an 8 ms 1-sigma; 1e-6, a constant, gave 35 ms against 1.8 ms) "
        "(s/sqrt(s))",
    )


class Outages(Section):
    """Simulated GNSS outages: periodic and/or explicit windows (GNSS time from the start)."""

    every_s: PositiveFloat | None = Field(None, description="spacing of periodic outages (s)")
    length_s: PositiveFloat | None = Field(None, description="length of each outage (s)")
    first_s: NonNegFloat | None = Field(
        None, description="start of the first, from the run start (s); default every_s"
    )
    count: PositiveInt | None = Field(
        None,
        description="at most this many periodic outages, e.g. 11 of 15 s every 45 s from "
        "40 s, a peer's placement; default as many as fit (1)",
    )
    windows: list[tuple[float, float]] = Field(
        [], description="explicit windows [start, end) (s, from the run start)"
    )

    @model_validator(mode="after")
    def _pair(self):
        if (self.every_s is None) != (self.length_s is None):
            raise KeyPathError(("length_s",), "periodic outages need both every_s and length_s")
        return self


class PostNoise(Section):
    """Process noise (lab units)."""

    arw_dps_rthz: NonNegFloat = Field(0.0038, le=10.0, description="gyro noise (deg/s/sqrt(Hz))")
    vrw_ug_rthz: NonNegFloat = Field(70.0, le=1e5, description="accel noise (ug/sqrt(Hz))")
    gyro_bias_walk_dps_rthz: NonNegFloat = Field(
        3.8e-5, le=1.0, description="gyro bias random walk (deg/s/sqrt(Hz))"
    )
    accel_bias_walk_ug_rthz: NonNegFloat = Field(
        7.0, le=1e5, description="accel bias random walk (ug/sqrt(Hz))"
    )
    factor: PositiveFloat = Field(
        3.0, le=100.0, description="multiplier on all densities (unmodelled errors; 1)"
    )

    @model_validator(mode="after")
    def _some_white_noise(self):
        if self.arw_dps_rthz == 0.0 and self.vrw_ug_rthz == 0.0:
            raise KeyPathError(
                ("arw_dps_rthz",),
                "the gyro and accelerometer noise are both 0: the filter would trust the "
                "integrated IMU forever and stop taking the GNSS; give the sensor's noise",
            )
        return self


class PostSigma(Section):
    """Initial 1-sigma (lab units), each within a range a real start can have."""

    position_m: Sigma(1e-4, 1e4) = Field(0.05, description="position, each axis (m)")
    velocity_mps: Sigma(1e-4, 1e3) = Field(0.05, description="velocity, each axis (m/s)")
    tilt_deg: Sigma(1e-5, 90.0) = Field(1.0, description="roll, pitch (deg)")
    heading_deg: Sigma(1e-5, 180.0) = Field(5.0, description="heading (deg)")
    accel_bias_ug: Sigma(1e-3, 1e6) = Field(1e4, description="accelerometer bias (ug)")
    gyro_bias_dps: Sigma(1e-7, 100.0) = Field(0.1, description="gyro bias (deg/s)")


class Stationary(Section):
    """Stationary detector on the IMU (inins.ekf.aiding): both below their thresholds."""

    accel_mps2: PositiveFloat = Field(
        0.05, description="RMS deviation of the specific force from its window mean (m/s^2)"
    )
    gyro_dps: PositiveFloat = Field(0.5, description="mean angular-rate magnitude (deg/s)")
    window_s: PositiveFloat = Field(0.5, description="window before each epoch (s)")


class Aiding(Section):
    """Vehicle constraints (0 = off)."""

    nhc_sigma_mps: NonNegFloat = Field(
        0.0, le=10.0, description="NHC: lateral and vertical vehicle velocity 1-sigma (m/s)"
    )
    odometer_sigma_mps: NonNegFloat = Field(
        0.0, le=10.0, description="odometer forward speed 1-sigma (m/s); needs imu.odometer_column"
    )
    zupt_sigma_mps: NonNegFloat = Field(
        0.0, le=10.0, description="ZUPT while stationary: velocity 1-sigma (m/s)"
    )
    zaru_sigma_dps: NonNegFloat = Field(
        0.0, le=10.0, description="ZARU while stationary: angular-rate 1-sigma (deg/s)"
    )
    mounting_deg: MountingAngles = Field(
        (0.0, 0.0, 0.0),
        description="roll, pitch, yaw of the IMU body in the vehicle axes, roll and yaw "
        "within 180, pitch within 90 (deg)",
    )
    stationary: Stationary = Field(default_factory=Stationary)
    stationary_windows_s: list[tuple[float, float]] | None = Field(
        None, description="stationary windows from the run start (s), instead of the detector"
    )


class OutlierGate(Section):
    """The outlier gate of each GNSS fix (inins.ekf.gate): the position (and velocity) of
    an epoch is rejected when its NIS, y^T S^-1 y with S = H P H^T + R, exceeds
    sigma_scale^2 times the chi-square(3) quantile of probability; after reinit_after
    consecutive rejected epochs the next failing fix re-initialises position (and
    velocity) from the solution with its sigma. Reference epochs that fail the same test
    against the solution are not scored."""

    probability: float = Field(
        0.999999,
        gt=0.5,
        le=1.0,
        description="acceptance probability of a fix whose innovation has the covariance "
        "tested, chi-square(3) (0.999999: 30.7 at sigma_scale 1); 1: no gate (1)",
    )
    sigma_scale: float = Field(
        10.0,
        ge=1.0,
        le=1000.0,
        description="the innovation sigma tested is this times the filter's: a MEMS filter "
        "on RTK fixes predicts its innovations up to 28 times too small on clean data "
        "(lc-drive NIS up to 790); 1: the filter's own (1)",
    )
    reinit_after: int = Field(
        10,
        ge=1,
        le=100_000,
        description="consecutive rejected epochs after which the next failing fix "
        "re-initialises position (and velocity) from the solution (1)",
    )


class PostProcess(Section):
    """Post-processing of a recorded drive with the loosely coupled filter."""

    coupling_mode: Literal["loose"] = Field(
        "loose", description="loose: GNSS solutions as the measurement (tight: use filter/data)"
    )
    imu: ImuLog = Field(description="the IMU log")
    gnss: GnssFile = Field(description="the GNSS solution file")
    time: TimeMapping = Field(default_factory=TimeMapping)
    lever_arm_m: LeverArm = Field(
        (0.0, 0.0, 0.0), description="antenna minus IMU, body axes (m), each within 100 m"
    )
    static_window_s: tuple[float, float] = Field(
        (1.0, 30.0), description="standing still, from the first GNSS epoch (s): levelling"
    )
    motion_speed_mps: PositiveFloat = Field(
        3.0, description="GNSS speed above which the motion gives the initial heading (m/s)"
    )
    init: Literal["motion", "reference"] = Field(
        "motion",
        description="motion: level on static_window_s, heading from the first motion; "
        "reference: attitude and velocity of the file's first epoch (gnss.attitude_columns)",
    )
    motion_heading_bound_deg: PositiveFloat = Field(
        10.0,
        le=180.0,
        description="init motion: the forward heading may differ from the GNSS course by "
        "this much (median over the first minute faster than motion_speed_mps after the "
        "static window) before the run fails its check, exit 1 (deg)",
    )
    init_heading_error_deg: float = Field(
        0.0, description="reference init: heading error added on purpose (deg), a convergence test"
    )
    score_from_s: NonNegFloat = Field(
        0.0, description="attitude scored against the reference from this time on (s)"
    )
    noise: PostNoise = Field(default_factory=PostNoise)
    initial_sigma: PostSigma = Field(default_factory=PostSigma)
    misalignments: bool = Field(False, description="24 states (+ misalignments) instead of 15")
    feedback: bool = Field(True, description="FB (fed back, reset) or FF")
    gate_probability: float = Field(
        1.0,
        gt=0.5,
        le=1.0,
        description="chi-square(1) gate per scalar row of the GNSS fixes that pass the outlier "
        "gate and of the vehicle aiding; 1: no gate (1)",
    )
    outlier_gate: OutlierGate = Field(default_factory=OutlierGate)
    smoother: Literal["rts", "none"] = Field("rts", description="backward RTS pass")
    aiding: Aiding = Field(default_factory=Aiding)
    outages: Outages = Field(default_factory=Outages)
    reference_q: int = Field(
        1, description="quality flag of the epochs the outages are scored against (1: fix)"
    )
    reference: ReferenceTrajectory | None = Field(
        None,
        description="an independent reference trajectory the forward and smoothed "
        "solutions are scored against, besides the reference_q epochs (section)",
    )
    export: list[Literal["csv", "pos", "geojson"]] = Field(
        [],
        description="trajectory files written beside the results, forward and smoothed with "
        "their 1-sigma, on GNSS time: csv (GPS week/seconds and UTC columns), pos (RTKLIB), "
        "geojson (a LineString per solution) (file formats)",
    )

    @model_validator(mode="after")
    def _window(self):
        if not self.static_window_s[1] > self.static_window_s[0] + 5.0:
            raise KeyPathError(("static_window_s",), "needs end > start + 5 s")
        return self
