"""Scenario of ``inins import-flight``: a GNSS recording (RINEX observation and
navigation files, or the PSINS tightly coupled MATLAB file with its IMU) into the
recorded-flight layout, with a single-point-positioning check of every epoch.

Paths are relative to the scenario file; RINEX files may be gzip-compressed.
"""

from typing import Literal

from pydantic import Field, model_validator

from inins.scenario.base import ScenarioModel, ScenarioPath
from inins.scenario.base import ScenarioSection as Section
from inins.scenario.run_ekf_post import GnssFile, ImuLog
from inins.scenario.types import NonNegFloat, PositiveFloat
from inins.scenario.validation import KeyPathError


class Spp(Section):
    """Single-point positioning of every epoch (the check of the recording)."""

    mask_deg: NonNegFloat = Field(10.0, le=90.0, description="elevation mask (deg)")
    ionosphere: Literal["auto", "iono-free", "klobuchar", "none"] = Field(
        "auto",
        description="auto: ionosphere-free P1/P2 where both exist, else Klobuchar when the "
        "navigation header carries it, else none; the report says which",
    )
    sigma_zenith_m: PositiveFloat = Field(
        1.5, description="pseudorange 1-sigma at zenith for the weights and the residual test (m)"
    )
    false_alarm: float = Field(
        1e-3, gt=0.0, lt=0.5, description="false-alarm probability of the residual test (1)"
    )
    max_exclusions: int = Field(
        1,
        ge=0,
        le=10,
        description="satellites the residual test may exclude one after another in an "
        "epoch (1: a station under open sky; several in a city) (1)",
    )
    snr_reference_dbhz: PositiveFloat | None = Field(
        None,
        le=70.0,
        description="carrier-to-noise weighting: below this C/N0 a row's sigma grows as "
        "10^((ref - C/N0) / 20); none: elevation weights only (dB-Hz)",
    )
    system_mask_deg: dict[Literal["G", "R", "E", "C"], NonNegFloat] = Field(
        default_factory=dict,
        description="elevation mask of a system instead of mask_deg, by RINEX letter (deg)",
    )
    system_sigma_scale: dict[Literal["G", "R", "E", "C"], PositiveFloat] = Field(
        default_factory=dict,
        description="pseudorange sigma of a system's rows as a multiple of sigma_zenith_m, "
        "by RINEX letter (1)",
    )


class ImportFlightScenario(ScenarioModel):
    """Import a GNSS recording into the recorded-flight layout and check it by SPP."""

    format: Literal["rinex", "psins-tc", "solution"] = Field(
        description="rinex: observation + navigation files (2.11 or 3.x; systems as in "
        "'systems'); psins-tc: the "
        "PSINS tightly coupled .mat file (imu, obss, ephs, t0); solution: a GNSS solution "
        "file (solution_gnss) joined to an IMU log (solution_imu), written in the "
        "recorded-solution layout that run-ekf's post: section reads"
    )
    solution_gnss: GnssFile | None = Field(
        None, description="solution: the GNSS solution file, as run-ekf's post.gnss"
    )
    solution_imu: ImuLog | None = Field(
        None, description="solution: the IMU log, as run-ekf's post.imu"
    )
    obs_file: ScenarioPath | None = Field(None, description="rinex: the observation file")
    nav_file: ScenarioPath | None = Field(None, description="rinex: the navigation file")
    file: ScenarioPath | None = Field(None, description="psins-tc: the .mat file")
    reference: Literal["none", "header"] = Field(
        "none",
        description="known antenna position for the error statistics: none, or the RINEX "
        "header's APPROX POSITION XYZ (a static station); or give reference_pos_e_m",
    )
    reference_pos_e_m: tuple[float, float, float] | None = Field(
        None, description="known antenna position, ECEF (m)"
    )
    static_window_imu_s: tuple[float, float] | None = Field(
        None,
        description="an interval of IMU time (s) where the vehicle stands: its SPP scatter "
        "and range-rate speed are reported",
    )
    imu_log: ScenarioPath | None = Field(
        None,
        description="rinex: an import-log scenario (a CSV, HDF5 or PSINS text log with its "
        "columns, units and axes) whose IMU increments join the GNSS record",
    )
    imu_t0_sow: float | None = Field(
        None,
        ge=0.0,
        lt=604800.0,
        description="GPS seconds of week of the IMU log's time 0 (s); needed with imu_log",
    )
    systems: str = Field(
        "G",
        pattern="^[GREC]+$",
        description="rinex: satellite systems to read and solve with, RINEX letters (G GPS, "
        "R GLONASS, E Galileo, C BeiDou), e.g. GR; one receiver clock plus a bias per "
        "further system",
    )
    extra_nav_files: list[ScenarioPath] = Field(
        default_factory=list,
        description="rinex: further navigation files (RINEX 2 .g GLONASS beside the GPS .n, "
        "or RINEX 3/4 of any system)",
    )
    leap_seconds: int | None = Field(
        None,
        ge=0,
        le=60,
        description="GPS - UTC (s) for GLONASS epochs when a navigation header lacks LEAP "
        "SECONDS (17 in 2016)",
    )
    reference_track: ScenarioPath | None = Field(
        None,
        description="a reference trajectory text file, rows [label] time X Y Z (s, ECEF m), "
        "such as the smartLoc ground truth: horizontal errors of every fix against it",
    )
    reference_track_offset_s: float = Field(
        0.0,
        description="GPS seconds of week minus the reference file's time (s)",
    )
    spp: Spp = Field(default_factory=Spp)

    @model_validator(mode="after")
    def _files(self):
        if self.format == "solution":
            for key in ("solution_gnss", "solution_imu"):
                if getattr(self, key) is None:
                    raise KeyPathError(
                        (key,), "format solution needs solution_gnss and solution_imu"
                    )
            for key in ("obs_file", "nav_file", "file", "imu_log", "reference_track"):
                if getattr(self, key) is not None:
                    raise KeyPathError((key,), "format solution reads only its two files")
            if self.solution_gnss.format == "recorded" or self.solution_imu.format == "recorded":
                raise KeyPathError(("format",), "format solution reads source files, not recorded")
            return self
        if self.solution_gnss is not None or self.solution_imu is not None:
            raise KeyPathError(
                ("solution_gnss",), "solution_gnss/solution_imu need format: solution"
            )
        if self.format == "rinex":
            for key in ("obs_file", "nav_file"):
                if getattr(self, key) is None:
                    raise KeyPathError((key,), "format rinex needs obs_file and nav_file")
        elif self.file is None:
            raise KeyPathError(("file",), "format psins-tc needs file")
        if self.format != "rinex" and (self.systems != "G" or self.extra_nav_files):
            raise KeyPathError(("systems",), "only RINEX files carry other systems")
        if len(set(self.systems)) != len(self.systems):
            raise KeyPathError(("systems",), f"a system given twice in {self.systems!r}")
        for key in ("system_mask_deg", "system_sigma_scale"):
            extra = set(getattr(self.spp, key)) - set(self.systems)
            if extra:
                raise KeyPathError(
                    ("spp", key),
                    f"system {sorted(extra)} is not enabled (systems: {self.systems})",
                )
        if self.imu_log is not None and self.format != "rinex":
            raise KeyPathError(("imu_log",), "the PSINS tc file carries its own IMU")
        if (self.imu_log is None) != (self.imu_t0_sow is None):
            raise KeyPathError(("imu_t0_sow",), "imu_log and imu_t0_sow go together")
        if self.reference == "header" and self.format != "rinex":
            raise KeyPathError(("reference",), "only a RINEX header carries a position")
        if self.reference == "header" and self.reference_pos_e_m is not None:
            raise KeyPathError(("reference_pos_e_m",), "give reference: header or a position")
        window = self.static_window_imu_s
        if window is not None and not window[1] > window[0]:
            raise KeyPathError(("static_window_imu_s",), "the end must be after the start")
        return self
