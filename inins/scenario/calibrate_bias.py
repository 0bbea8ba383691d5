"""Scenario of ``inins calibrate-bias`` (spec §4): the data, the alignment, the sequence,
the navigation mode and the noise figures for the 1-sigma."""

from typing import Literal

from pydantic import Field, model_validator

from inins.scenario.base import InputFile, ScenarioSection
from inins.scenario.simulate_table import TableSource
from inins.scenario.types import NonNegFloat, NonNegVec3, PositiveFloat
from inins.scenario.validation import KeyPathError


class AlignmentSettings(ScenarioSection):
    """Initial alignment at the first position of the return sequence (000 §2)."""

    method: Literal["gyrocompass", "known", "ett"] = Field(
        "gyrocompass",
        description="gyrocompass: coarse levelling + gyrocompassing; known: "
        "levelling + the heading given; ett: levelling + the heading from the ETT mounting "
        "(000 §3.1): an align-ett result (ett_file), or computed from the pitch-90/0 "
        "positions in the same data",
    )
    duration_s: PositiveFloat = Field(
        300.0, description="alignment time at the start of the first position (s)"
    )
    heading_deg: float | None = Field(
        None,
        description="IMU heading at the first position "
        "for method known, clockwise from north (deg)",
    )
    heading_sigma_arcsec: NonNegFloat = Field(
        0.0, le=36000.0, description="1-sigma of a known heading, at most 10 deg (arcsec)"
    )
    gyro_bias_bound_dph: NonNegFloat | None = Field(
        None,
        description="largest gyro bias the unit may have, from its data sheet (deg/h); gyrocompass "
        "alignment is refused where it reaches half the horizontal Earth rate W cos(lat) "
        "(heading error 30 deg). Default: the simulated bias, else checked on the result",
    )
    ett_file: InputFile | None = Field(
        None,
        description="align-ett.h5 written by inins align-ett on the same mounting, "
        "for method ett (relative to this scenario file); default: ETT on this data",
    )

    @model_validator(mode="after")
    def _needs(self):
        if self.method == "known" and self.heading_deg is None:
            raise KeyPathError(("heading_deg",), "method known needs heading_deg")
        return self


class SequenceSettings(ScenarioSection):
    """Where the 000 Table 1 return sequence is and how its epochs are read."""

    labels: list[str] | None = Field(
        None,
        min_length=3,
        max_length=3,
        description="labels of a hold at A, at B (A "
        "turned 180 deg) and back at A; default: the first such triple found",
    )
    vertical_labels: list[str] | None = Field(
        None,
        min_length=3,
        max_length=3,
        description="labels of a hold at A, B and A' of the second return sequence, with the "
        "pitch gimbal at 90 deg (body z horizontal) for beta_z; default: the first later "
        "return sequence whose vertical body axis is not the level one's, if any",
    )
    epoch_window_s: PositiveFloat = Field(
        5.0, description="each epoch tilt is the mean over this window (s)"
    )
    settle_s: NonNegFloat = Field(2.0, description="time skipped after a rotation (s)")


class NavigationSettings(ScenarioSection):
    """How the sequence is navigated."""

    mode: Literal["stationary", "free"] = Field(
        "stationary",
        description="stationary: known position and zero velocity, no "
        "transport rate and no Coriolis, so the tilt follows the gyro biases without "
        "Schuler feedback (000 eqs. 9-10); free (free-inertial) is refused: the methods "
        "assume a fixed position and the Schuler loop would bias them (-12 %/-41 % at "
        "T = 600 s)",
    )
    output_rate_hz: PositiveFloat = Field(
        10.0, description="rate of the navigation output the methods use (Hz)"
    )


class NoiseSettings(ScenarioSection):
    """Sensor noise for the 1-sigma of each estimate. Not given: the simulation's own
    figures with a ``simulate:`` section, else estimated from the alignment window."""

    arw_deg_rth: NonNegVec3 | None = Field(None, description="gyro angle random walk (deg/sqrt(h))")
    vrw_ug_rthz: NonNegFloat | None = Field(
        None, description="accelerometer velocity random walk (ug/sqrt(Hz))"
    )
    accel_pulse_weight_ug_s: NonNegFloat | None = Field(
        None, description="accelerometer pulse weight (ug*s), adds quantization noise"
    )


class MountDetection(ScenarioSection):
    """Detecting the mount rotation from the return to the start attitude (000 eqs. 35, 43)."""

    k_sigma: PositiveFloat = Field(
        4.0, description="a residual larger than k_sigma times its 1-sigma is a mount rotation (1)"
    )
    floor_arcsec: NonNegFloat = Field(0.5, description="and larger than this (arcsec)")


class StatedErrorSettings(ScenarioSection):
    """1-sigma of the sensor errors calibrate-bias does not estimate (the unit's data sheet
    or a previous calibration), for the uncertainty budget of each chosen bias: each
    enters through its exact sensitivity along the sequence (issue 7 item 6)."""

    accel_bias_ug: NonNegFloat = Field(
        0.0, description="accelerometer bias per horizontal axis, 1 sigma (ug): levelling tilt"
    )
    gyro_bias_z_dph: NonNegFloat = Field(
        0.0,
        description="error of the vertical gyro bias taken as known (gyro_bias_z_dph), "
        "1 sigma (deg/h)",
    )
    gyro_scale_ppm: NonNegVec3 = Field(0.0, description="gyro scale factor, 1 sigma (ppm)")
    gyro_misalignment_arcsec: NonNegFloat = Field(
        0.0, description="each of the six gyro misalignments, 1 sigma (arcsec)"
    )
    gyro_bias_instability_dph: NonNegFloat = Field(
        0.0, description="Gauss-Markov gyro bias instability, 1 sigma (deg/h)"
    )
    gyro_bias_corr_time_s: PositiveFloat = Field(3600.0, description="its correlation time (s)")


class CalibrateBiasScenario(TableSource):
    """Horizontal gyro-bias calibration from a rate-table return sequence (000 §2-3)."""

    alignment: AlignmentSettings = Field(default_factory=AlignmentSettings)
    sequence: SequenceSettings = Field(default_factory=SequenceSettings)
    navigation: NavigationSettings = Field(default_factory=NavigationSettings)
    noise: NoiseSettings = Field(default_factory=NoiseSettings)
    mount_detection: MountDetection = Field(default_factory=MountDetection)
    uncertainty: StatedErrorSettings = Field(default_factory=StatedErrorSettings)
    compensation: InputFile | None = Field(
        None,
        description="a compensation file (written by calibrate-imu) applied to the table "
        "data's increments before the methods run; relative to this scenario file",
    )
    compensation_serial: str | None = Field(
        None,
        description="serial of the unit in the data: a compensation file made for "
        "another serial is refused",
    )
    gyro_bias_z_dph: float = Field(
        0.0,
        description="vertical gyro bias taken as known (deg/h); 000 calibrates the horizontal ones",
    )
    paper000_case: Literal[1, 2, 3, 4] | None = Field(
        None, description="print the numbers of 000 §3.2 case 1-4 beside ours (1)"
    )
