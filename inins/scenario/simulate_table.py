"""Scenario of ``inins simulate-table`` (spec §3): table, mount, IMU, disturbances, motion."""

from typing import Annotated, Literal

import numpy as np
from pydantic import Field, field_validator, model_validator

from inins.core import rotation
from inins.core.units import ARCSEC
from inins.scenario.base import (
    ScenarioModel,
    ScenarioPath,
    input_file_problem,
    loaded_from_file,
)
from inins.scenario.base import ScenarioSection as Section
from inins.scenario.common import Imu, Site
from inins.scenario.types import NonNegFloat, PositiveFloat, Vec3
from inins.scenario.validation import KeyPathError

DIRECTIONS = {
    "forward": (1.0, 0.0, 0.0),
    "back": (-1.0, 0.0, 0.0),
    "right": (0.0, 1.0, 0.0),
    "left": (0.0, -1.0, 0.0),
    "down": (0.0, 0.0, 1.0),
    "up": (0.0, 0.0, -1.0),
}
Direction = Literal["forward", "back", "right", "left", "down", "up"]
GimbalName = Literal["yaw", "pitch", "roll"]


class Table(Section):
    """The rate table. Its platform frame t is forward-right-down at zero gimbal angles."""

    gimbals: list[GimbalName] = Field(
        ["yaw", "pitch"],
        min_length=2,
        max_length=3,
        description="gimbal axes, outer first: 2 or 3 of yaw (table z), pitch (y), roll (x)",
    )
    initial_angles_deg: list[float] | None = Field(
        None, description="gimbal angles at the start (deg), outer first; default all 0"
    )
    base_azimuth_deg: float = Field(
        0.0, description="azimuth of the table x axis at zero yaw, clockwise from north (deg)"
    )
    base_tilt_arcsec: list[float] = Field(
        [0.0, 0.0],
        min_length=2,
        max_length=2,
        description="roll and pitch of the table base from level (arcsec)",
    )
    axis_nonorthogonality_arcsec: list[list[float]] | None = Field(
        None,
        description="per gimbal, outer first: small tilts of the axis toward the two "
        "other table axes in cyclic order (arcsec); default none",
    )
    encoder_noise_arcsec: NonNegFloat = Field(
        0.0, description="white noise of the encoder readings, 1 sigma (arcsec)"
    )
    accel_dps2: PositiveFloat = Field(
        20.0, description="angular acceleration of rotate and spin steps (deg/s^2)"
    )

    @field_validator("gimbals")
    @classmethod
    def _distinct(cls, value):
        if len(set(value)) != len(value):
            raise ValueError("each gimbal axis may appear once")
        return value

    @model_validator(mode="after")
    def _lengths(self):
        n = len(self.gimbals)
        if self.initial_angles_deg is not None and len(self.initial_angles_deg) != n:
            raise ValueError(f"initial_angles_deg needs {n} angles, one per gimbal")
        nonorth = self.axis_nonorthogonality_arcsec
        if nonorth is not None and (len(nonorth) != n or any(len(r) != 2 for r in nonorth)):
            raise ValueError(f"axis_nonorthogonality_arcsec needs {n} pairs, one per gimbal")
        return self


class MountDisturbance(Section):
    """A slow rotation of the IMU on its anti-vibration mount (000 §3.2)."""

    axis: Literal["x", "y", "z"] = Field(
        description="IMU body axis of the rotation (000's roll axis is the forward axis, "
        "its pitch axis the right axis)"
    )
    angle_deg: float = Field(description="total rotation (deg), e.g. 0.005")
    start_s: NonNegFloat = Field(0.0, description="start time (s)")
    duration_s: PositiveFloat = Field(description="time over which it happens (s), e.g. 2T")
    shape: Literal["linear", "smooth"] = Field(
        "linear", description="linear: constant rate; smooth: (1 - cos) ramp"
    )


class Mount(Section):
    """How the IMU sits on the table platform."""

    imu_axes: list[Direction] = Field(
        ["forward", "right", "down"],
        min_length=3,
        max_length=3,
        description="table directions of the IMU x, y, z axes; 000 uses right, forward, up",
    )
    misalignment_arcsec: Vec3 = Field(
        0.0, description="constant small rotation of the IMU about its x, y, z axes (arcsec)"
    )
    rotations: list[MountDisturbance] = Field(
        [], description="time-varying mount rotations (disturbance of 000 §3.2)"
    )

    @field_validator("imu_axes")
    @classmethod
    def _right_handed(cls, value):
        mat = np.array([DIRECTIONS[v] for v in value]).T
        if not np.allclose(mat.T @ mat, np.eye(3)) or np.linalg.det(mat) < 0:
            raise ValueError("the three directions must form a right-handed triad")
        return value

    def nominal(self):
        """IMU body -> table platform as the IMU axes are named (no misalignment)."""
        return np.array([DIRECTIONS[v] for v in self.imu_axes]).T

    def mat_tb0(self):
        """IMU body -> table platform with the mount at rest."""
        return self.nominal() @ rotation.mat_from_rotvec(
            np.array(self.misalignment_arcsec) * ARCSEC
        )


class AfterRotation(Section):
    """Accelerometer bias change after every rotation (000 §2, Fig. 2: ~50 ug)."""

    step_ug: Vec3 = Field(description="bias change added by each rotation (ug), x y z")
    settle_time_s: NonNegFloat = Field(
        0.0, description="exponential time constant of the change (s); 0 = a step"
    )


class ChamberProfile(Section):
    """Chamber temperature offset from the sensors' reference, piecewise linear."""

    time_s: list[float] = Field(min_length=1, description="times (s), increasing")
    delta_degc: list[float] = Field(min_length=1, description="temperature offsets (degC)")

    @model_validator(mode="after")
    def _consistent(self):
        if len(self.time_s) != len(self.delta_degc):
            raise ValueError("time_s and delta_degc need the same length")
        if np.any(np.diff(self.time_s) <= 0):
            raise ValueError("time_s must increase")
        return self


class Disturbances(Section):
    """Disturbances of 000 §2 on top of the sensor error model."""

    accel_bias_after_rotation: AfterRotation | None = None
    chamber: ChamberProfile | None = None


class HoldStep(Section):
    """Stand still."""

    kind: Literal["hold"] = Field(description="step type")
    duration_s: PositiveFloat = Field(description="hold time (s)")
    label: str = Field("", description="name of the position, used in reports")


class RotateStep(Section):
    """Turn one gimbal by an angle, rest to rest."""

    kind: Literal["rotate"] = Field(description="step type")
    axis: GimbalName = Field(description="gimbal to turn")
    angle_deg: float = Field(
        description="signed angle (deg); positive is right-handed "
        "about the gimbal axis (yaw: clockwise seen from above)"
    )
    rate_dps: PositiveFloat = Field(10.0, description="cruise rate (deg/s)")
    label: str = Field("", description="name shown in reports")


class SpinStep(Section):
    """Spin one gimbal at constant rate (rate tests)."""

    kind: Literal["spin"] = Field(description="step type")
    axis: GimbalName = Field(description="gimbal to spin")
    rate_dps: float = Field(description="signed spin rate (deg/s)")
    duration_s: PositiveFloat = Field(description="time at full rate (s)")
    label: str = Field("", description="name shown in reports")


Step = Annotated[HoldStep | RotateStep | SpinStep, Field(discriminator="kind")]


class Output(Section):
    """What is kept besides the IMU increments."""

    truth_rate_hz: PositiveFloat = Field(
        10.0, description="rate of the truth and encoder series (Hz); must divide the IMU rate"
    )


class TableSetup(Section):
    """An IMU on a 2- or 3-axis rate table running a motion program (the simulate-table
    scenario without seed and checks, for use as a ``simulate:`` section)."""

    site: Site = Field(default_factory=Site)
    table: Table = Field(default_factory=Table)
    mount: Mount = Field(default_factory=Mount)
    imu: Imu = Field(default_factory=Imu)
    disturbances: Disturbances = Field(default_factory=Disturbances)
    motion: list[Step] = Field(min_length=1, description="motion program, in order")
    output: Output = Field(default_factory=Output)

    @model_validator(mode="after")
    def _cross_checks(self):
        ratio = self.imu.sample_rate_hz / self.output.truth_rate_hz
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise KeyPathError(
                ("output", "truth_rate_hz"),
                f"must divide imu.sample_rate_hz ({self.imu.sample_rate_hz} Hz)",
            )
        for i, step in enumerate(self.motion):
            if getattr(step, "axis", None) is not None and step.axis not in self.table.gimbals:
                raise KeyPathError(
                    ("motion", i, "axis"),
                    f"the table has no {step.axis} gimbal (table.gimbals = {self.table.gimbals})",
                )
        return self


class SimulateTableScenario(TableSetup, ScenarioModel):
    """An IMU on a 2- or 3-axis rate table running a motion program."""


class TableSource(ScenarioModel):
    """Top level of a scenario that reads a table record: a file, or a simulation."""

    data: ScenarioPath | None = Field(
        None,
        description="table-data HDF5 (simulate-table or import-log output), relative "
        "to this scenario file; give this or simulate",
    )
    simulate: TableSetup | None = Field(
        None,
        description="a simulate-table scenario run in memory instead of reading data "
        "(so one scenario is one run of a sweep); give this or data",
    )

    @model_validator(mode="after")
    def _one_source(self, info):
        if (self.data is None) == (self.simulate is None):
            raise KeyPathError(
                ("data",),
                "give either data (a table-data file) or a "
                "simulate: section, not both and not neither",
            )
        problem = None
        if self.data is not None and loaded_from_file(info):
            problem = input_file_problem(self.data)
        if problem:
            raise KeyPathError(("data",), problem)
        return self
