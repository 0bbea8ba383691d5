"""Scenario of ``inins calibrate-imu``: every error term of both triads, on a rate table
or without one, the schedule checked by the planner, and the compensation file."""

from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from inins.scenario.base import (
    InputFile,
    ScenarioModel,
    ScenarioPath,
    ScenarioSection,
    input_file_problem,
    loaded_from_file,
)
from inins.scenario.simulate_table import DIRECTIONS, Direction, TableSetup
from inins.scenario.types import NonNegFloat, NonNegVec3, PositiveFloat, Vec3
from inins.scenario.validation import KeyPathError

Group = Literal[
    "accel_bias",
    "gyro_bias",
    "accel_scale",
    "gyro_scale",
    "accel_misalignment",
    "gyro_misalignment",
    "gyro_g_sensitivity",
    "mount",
]
SENSOR_GROUPS = [
    "accel_bias",
    "gyro_bias",
    "accel_scale",
    "gyro_scale",
    "accel_misalignment",
    "gyro_misalignment",
]
Method = Literal["discrete", "table-free", "system-level"]


class Unit(ScenarioSection):
    """The unit under calibration (for the certificate and the compensation file)."""

    name: str = Field("IMU", description="model or name of the unit")
    serial: str = Field("unknown", description="serial number; a compensation file names it")
    description: str = Field("", description="free text shown on the certificate")


class RawLog(ScenarioSection):
    """A raw-count log without a table: one text file per triad, rows of time (s) and
    x y z counts (the layout of the imu_tk test data)."""

    accel_file: InputFile = Field(description="accelerometer counts, relative to this scenario")
    gyro_file: InputFile = Field(description="gyro counts, same rows, relative to this scenario")
    accel_offset_counts: Vec3 = Field(32768.0, description="nominal zero of the accelerometers")
    gyro_offset_counts: Vec3 = Field(32768.0, description="nominal zero of the gyros")
    accel_scale_mps2_per_count: PositiveFloat | None = Field(
        None,
        description="nominal accelerometer scale (m/s^2 per count); default: the one that "
        "makes the first static interval read gravity (a one-point scale)",
    )
    gyro_scale_rad_s_per_count: PositiveFloat = Field(
        1.0 / 6258.0, description="nominal gyro scale (rad/s per count), imu_tk: 1/6258"
    )
    saturation_counts: list[float] = Field(
        [0.0, 65535.0],
        min_length=2,
        max_length=2,
        description="lowest and highest count the converter gives; a sample at either "
        "is saturated and refused",
    )


class Noise(ScenarioSection):
    """Sensor white noise for the weights and the 1-sigma. Not given: the simulation's own
    figures with a simulate: section, else estimated from the scatter within the holds."""

    arw_deg_rth: NonNegVec3 | None = Field(None, description="gyro angle random walk (deg/sqrt(h))")
    vrw_ug_rthz: NonNegVec3 | None = Field(
        None, description="accelerometer velocity random walk (ug/sqrt(Hz))"
    )
    gyro_pulse_weight_arcsec: NonNegVec3 | None = Field(
        None, description="gyro pulse weight (arcsec); 0 = not quantized"
    )
    accel_pulse_weight_ug_s: NonNegVec3 | None = Field(
        None, description="accelerometer pulse weight (ug*s); 0 = not quantized"
    )
    encoder_noise_arcsec: NonNegFloat | None = Field(
        None, description="white noise of one encoder reading (arcsec)"
    )


class PlanSettings(ScenarioSection):
    """The planner: observability of the requested terms from the motion program alone."""

    only: bool = Field(
        False, description="run the planner only (no data needed, nothing estimated)"
    )
    allow_combinations: bool = Field(
        False,
        description="estimate the separable combinations instead of refusing a schedule "
        "that cannot separate a requested term (those terms are reported without sigma)",
    )
    max_sigma_ppm: NonNegFloat | None = Field(
        None,
        description="refuse the schedule when a requested scale factor's predicted "
        "1-sigma exceeds this (ppm)",
    )


class StaticDetector(ScenarioSection):
    """Static intervals found from the data (Tedaldi et al. 2014 §IV-A, as imu_tk): the
    variance of each accelerometer axis over a sliding window, summed (its norm), below
    threshold_factor times that of the initial static interval."""

    window_s: PositiveFloat = Field(1.0, description="sliding window (s); imu_tk: 101 samples")
    init_interval_s: PositiveFloat = Field(
        30.0, description="initial static interval the threshold is scaled from (s)"
    )
    threshold_factor: PositiveFloat = Field(
        6.0, description="threshold as a multiple of the initial interval's variance norm (1)"
    )
    min_interval_s: PositiveFloat = Field(
        2.0, description="shortest static interval kept (s); shorter ones are flagged"
    )
    max_tilt_change_deg: PositiveFloat = Field(
        0.2,
        description="largest change of the gravity direction within one static interval "
        "(deg); above it the interval is flagged as moving and dropped",
    )


class TableFree(ScenarioSection):
    """The table-free multi-position method (Tedaldi, Pretto, Menegatti, ICRA 2014)."""

    gravity_mps2: PositiveFloat | None = Field(
        None,
        description="local gravity (m/s^2); default: normal gravity at the table's site, "
        "9.80665 for a raw log",
    )
    earth_rate: Literal["model", "imu_tk"] = Field(
        "model",
        description="model: the Earth rate at the latitude is in the model (the heading of "
        "the first position estimated with the gyro terms; every static interval a "
        "gyrocompass), so the gyro bias is the sensor's alone; imu_tk: as imu_tk, the "
        "Earth rate left in the data (the gyro bias carries the Earth rate of the first "
        "position, up to 15 deg/h, and the gyro terms the Earth rate times the motion time)",
    )
    lat_deg: float | None = Field(
        None,
        ge=-90.0,
        le=90.0,
        description="latitude of the lab (deg) for a raw log with earth_rate: model "
        "(a table record or simulation gives its site's)",
    )
    detector: StaticDetector = Field(default_factory=StaticDetector)
    use_positions: list[int] | None = Field(
        None,
        description="indices of the detected static intervals to use (0-based); default all",
    )


class SystemLevel(ScenarioSection):
    """System-level calibration: a Kalman filter on the navigation errors of the rotation
    sequence, known position and zero velocity."""

    step_s: PositiveFloat = Field(
        1.0, le=60.0, description="filter step (s), at most 60 (the linear model per step)"
    )
    velocity_noise_mps: PositiveFloat = Field(
        1e-4,
        ge=1e-7,
        le=1.0,
        description="1-sigma of the zero-velocity measurement (m/s): table vibration and "
        "velocity quantization; 1e-7 (a tenth of a micrometre per second) to 1",
    )


class Certificate(ScenarioSection):
    """What the calibration certificate says besides the results."""

    laboratory: str = Field("", description="calibrating laboratory")
    operator: str = Field("", description="who ran the calibration")
    procedure: str = Field("", description="procedure or document reference")


class CalibrateImuScenario(ScenarioModel):
    """Calibration of every error term of a gyro and an accelerometer triad."""

    unit: Unit = Field(default_factory=Unit)
    methods: list[Method] = Field(
        ["discrete"],
        min_length=1,
        description="discrete: positions and rate tests against the table encoders; "
        "table-free: gravity norm and integrated rotations (no encoders); system-level: "
        "Kalman filter on navigation errors; several are reported side by side",
    )
    data: ScenarioPath | None = Field(
        None, description="table-data HDF5 (simulate-table or import-log output)"
    )
    simulate: TableSetup | None = Field(
        None, description="a simulate-table scenario run in memory instead of reading data"
    )
    log: RawLog | None = Field(None, description="a raw-count log without a table (table-free)")
    imu_axes: list[Direction] | None = Field(
        None,
        min_length=3,
        max_length=3,
        description="nominal table directions of the IMU x, y, z axes for a data file "
        "(the reference of the discrete method); default forward, right, down; a "
        "simulate: section gives its mount.imu_axes",
    )
    estimate: list[Group] = Field(
        [*SENSOR_GROUPS, "mount"],
        min_length=1,
        description="term groups the discrete method estimates; the others are held at "
        "zero. mount: the small rotation of the triad from its nominal mounting on the "
        "table. The table-free and system-level methods always estimate the 21 sensor terms",
    )
    settle_s: NonNegFloat = Field(2.0, description="time skipped at the start of each hold (s)")
    noise: Noise = Field(default_factory=Noise)
    plan: PlanSettings = Field(default_factory=PlanSettings)
    table_free: TableFree = Field(default_factory=TableFree)
    system_level: SystemLevel = Field(default_factory=SystemLevel)
    compensation: InputFile | None = Field(
        None,
        description="a compensation file (written by calibrate-imu) applied to the raw "
        "data first: the terms found are then what it left",
    )
    certificate: Certificate = Field(default_factory=Certificate)

    @model_validator(mode="after")
    def _one_source(self, info):
        given = [k for k in ("data", "simulate", "log") if getattr(self, k) is not None]
        if len(given) != 1 and not (self.plan.only and self.simulate is not None):
            raise KeyPathError(
                (given[1] if len(given) > 1 else "data",),
                "give exactly one of data (a table-data file), simulate (a simulate-table "
                f"section) or log (raw counts); got {given or 'none'}",
            )
        if self.data is not None and loaded_from_file(info):
            problem = input_file_problem(self.data)
            if problem:
                raise KeyPathError(("data",), problem)
        if self.log is not None:
            bad = [m for m in self.methods if m != "table-free"]
            if bad:
                raise KeyPathError(
                    ("methods",), f"a raw log without a table allows only table-free, not {bad}"
                )
        if self.imu_axes is not None:
            mat = np.array([DIRECTIONS[v] for v in self.imu_axes]).T
            if not np.allclose(mat.T @ mat, np.eye(3)) or np.linalg.det(mat) < 0:
                raise KeyPathError(("imu_axes",), "the three directions must be right-handed")
        if len(set(self.methods)) != len(self.methods):
            raise KeyPathError(("methods",), "each method may appear once")
        return self


class CompensationImu(ScenarioSection):
    """Sensor error terms in the keys of a scenario's imu section (plus g-sensitivity)."""

    gyro_bias_dph: Vec3 = Field(0.0, description="gyro bias (deg/h)")
    gyro_scale_ppm: Vec3 = Field(0.0, description="gyro scale-factor error (ppm)")
    gyro_misalignment_arcsec: dict[Literal["xy", "xz", "yx", "yz", "zx", "zy"], float] = Field(
        {}, description="gyro i toward axis j (arcsec)"
    )
    gyro_g_sensitivity_dph_per_g: list[list[float]] | None = Field(
        None, description="gyro i per specific force along j (deg/h per g), 3 x 3"
    )
    accel_bias_ug: Vec3 = Field(0.0, description="accelerometer bias (ug)")
    accel_scale_ppm: Vec3 = Field(0.0, description="accelerometer scale-factor error (ppm)")
    accel_misalignment_arcsec: dict[Literal["yx", "zx", "zy"], float] = Field(
        {}, description="accelerometer i toward axis j (arcsec)"
    )


class CompensationFile(ScenarioSection):
    """A compensation file written by calibrate-imu."""

    format: Literal["inins-compensation"] = Field(description="file type")
    version: Literal[1] = Field(description="format version")
    unit: Unit = Field(description="the unit it was made for")
    calibrated: str = Field("", description="UTC time of the calibration")
    method: str = Field("", description="the method the terms come from")
    model: str = Field("", description="the method's model: what its gyro bias includes")
    not_determined: list[str] = Field(
        [],
        description="terms the schedule did not separate (left at zero, not compensated)",
    )
    imu: CompensationImu = Field(description="the error terms the compensation removes")
