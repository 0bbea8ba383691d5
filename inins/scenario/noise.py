"""Scenario of ``inins noise``: noise characterisation of an IMU at rest.

Input: exactly one of

- ``log:`` a lab log in any import-log format (CSV, HDF5, PSINS text) with the same
  ``log``, ``gyro``, ``accel``, ``body_axes`` and ``site`` keys as import-log
  (:mod:`inins.scenario.import_log`; the site is optional here);
- ``data:`` a table-data HDF5 file (simulate-table or import-log output);
- ``simulate:`` a simulate-table scenario run in memory (a static hold; its
  ``imu:`` block is the sensor error model ``inins noise`` writes).

The record is read in chunks and never held whole (except for the optional modified
and total deviations, which need it: ``deviation.mdev`` / ``deviation.totdev``).
"""

from typing import Literal

from pydantic import Field, model_validator

from inins.scenario.base import ScenarioModel, ScenarioPath
from inins.scenario.base import ScenarioSection as Section
from inins.scenario.import_log import AxisSign, Log, LogAccel, LogGyro, LogSite
from inins.scenario.simulate_table import TableSetup
from inins.scenario.types import NonNegFloat, PositiveFloat
from inins.scenario.validation import KeyPathError

TERM_KEYS = ("quantization", "random_walk", "bias_instability", "rate_random_walk", "rate_ramp")


class DeviationSettings(Section):
    """Which deviations, on which tau grid."""

    per_octave: int = Field(
        1, ge=1, le=16, description="tau points per octave (1: tau0, 2 tau0, 4 tau0, ...)"
    )
    offsets: int = Field(
        16,
        ge=0,
        le=4096,
        description="streaming overlapping Allan deviation: above this many starts per "
        "tau, every 2^l-th start is used (this many per tau); 0 = all starts "
        "(fully overlapping, slower on long records)",
    )
    max_tau_s: PositiveFloat | None = Field(
        None,
        description="longest tau wanted (s); the record must be at least 4 times "
        "as long (else bad input); default the longest the record allows",
    )
    mdev: bool = Field(
        False, description="also the modified Allan deviation (holds the record in memory)"
    )
    totdev: bool = Field(False, description="also the total deviation (holds the record in memory)")
    in_memory_limit: int = Field(
        1 << 24,
        ge=1000,
        description="largest record (samples) mdev and totdev may hold in memory",
    )
    band_confidence: float = Field(
        0.683,
        gt=0.0,
        lt=1.0,
        description="confidence of the band drawn and stored with each deviation "
        "(0.683: 1 sigma, as Stable32)",
    )


class FitSettings(Section):
    """The IEEE 952 five-term fit."""

    terms: list[Literal[TERM_KEYS]] = Field(
        list(TERM_KEYS),
        min_length=1,
        description="terms fitted: quantization, random_walk (ARW/VRW), bias_instability, "
        "rate_random_walk, rate_ramp",
    )
    confidence: float = Field(
        0.95, gt=0.0, lt=1.0, description="confidence of each term's interval"
    )
    min_tau_s: NonNegFloat = Field(0.0, description="fit only tau at or above this (s)")
    max_tau_s: PositiveFloat | None = Field(None, description="fit only tau up to this (s)")


class StaticSettings(Section):
    """The record must be static: motion, flat (saturated or stuck) sensors."""

    window_s: tuple[float, float] | None = Field(
        None,
        description="use only this part [start, end] from the first sample (s); default all",
    )
    motion: Literal["refuse", "cut"] = Field(
        "refuse",
        description="refuse: motion in the record is bad input; cut: keep the longest "
        "static part (a warning names it)",
    )
    block_s: PositiveFloat = Field(1.0, description="motion is looked for in blocks of this (s)")
    motion_sigma: PositiveFloat = Field(
        10.0,
        description="a block moves when its mean rate or specific force is this many "
        "robust sigmas (of the block means) from the median",
    )
    motion_floor_dph: NonNegFloat = Field(
        10.0,
        description="... and further than this from the median gyro rate (deg/h)",
    )
    motion_floor_ug: NonNegFloat = Field(
        1000.0,
        description="... or further than this from the median specific force (ug)",
    )
    guard_s: NonNegFloat = Field(
        5.0, description="cut: moving blocks are widened by this on both sides (s)"
    )
    gyro_range_dps: PositiveFloat | None = Field(
        None, description="gyro measuring range (deg/s); a sample at it is saturated"
    )
    accel_range_g: PositiveFloat | None = Field(
        None, description="accelerometer range (g, 9.80665 m/s^2); a sample at it is saturated"
    )


class OutputSettings(Section):
    """The sensor error-model blocks written beside the results."""

    kalibr_topic: str = Field("/imu0", description="rostopic of the Kalibr imu.yaml")
    bias_corr_time_s: PositiveFloat | None = Field(
        None,
        description="correlation time of the Gauss-Markov bias written for "
        "simulate-table (s); default from the tau of the Allan minimum",
    )


class NoiseScenario(ScenarioModel):
    """Noise characterisation of an IMU at rest: Allan deviation, fitted noise terms,
    sensor error-model blocks."""

    log: Log | None = Field(None, description="a lab log (import-log keys); or data, simulate")
    gyro: LogGyro = Field(default_factory=LogGyro, description="what the gyro columns hold")
    accel: LogAccel = Field(
        default_factory=LogAccel, description="what the accelerometer columns hold"
    )
    body_axes: list[AxisSign] = Field(
        ["+x", "+y", "+z"],
        min_length=3,
        max_length=3,
        description="log axis and sign of body x, y, z (as import-log)",
    )
    site: LogSite = Field(
        default_factory=LogSite, description="where the log was recorded (optional here)"
    )
    data: ScenarioPath | None = Field(
        None, description="a table-data HDF5 file, relative to this scenario file"
    )
    simulate: TableSetup | None = Field(
        None, description="a simulate-table scenario (a static hold) run in memory"
    )
    deviation: DeviationSettings = Field(default_factory=DeviationSettings)
    fit: FitSettings = Field(default_factory=FitSettings)
    static: StaticSettings = Field(default_factory=StaticSettings)
    output: OutputSettings = Field(default_factory=OutputSettings)

    @model_validator(mode="after")
    def _one_source(self):
        given = [k for k in ("log", "data", "simulate") if getattr(self, k) is not None]
        if len(given) != 1:
            raise KeyPathError(
                ("log",),
                "give exactly one input: log (a lab log), data (a table-data file) or "
                f"simulate (a simulate-table scenario); got {', '.join(given) or 'none'}",
            )
        if self.simulate is not None:
            for i, step in enumerate(self.simulate.motion):
                if step.kind != "hold":
                    raise KeyPathError(
                        ("simulate", "motion", i, "kind"),
                        "noise needs a static record: every step a hold",
                    )
        w = self.static.window_s
        if w is not None and not w[1] > w[0] >= 0:
            raise KeyPathError(("static", "window_s"), "needs 0 <= start < end (s)")
        f = self.fit
        if f.max_tau_s is not None and f.max_tau_s <= f.min_tau_s:
            raise KeyPathError(("fit", "max_tau_s"), "must be above fit.min_tau_s")
        return self
