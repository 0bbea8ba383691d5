"""Scenario of ``inins observability`` (spec §7, paper 002): an error-state model,
aiding measurements, satellite geometry, and piecewise-constant segments (listed, cut
from a trajectory file, or cut from the simulated flight of a run-ekf scenario), with
the priors of the covariance analysis.

Segments: each entry is one constant operating point held for ``duration_s``. The
attitude is a heading (level body) or roll, pitch and heading; the velocity is NED
or a ground speed along the heading; the specific force and body rate default to
unaccelerated flight (``f_n = (2 w_ie + w_en) x v - g``, body fixed in the
navigation frame) and may be given in the body frame (``f_b_mps2``,
``omega_b_dps``) for a turn, a climb or a table position.
"""

from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from inins.core.error_model import GROUPS
from inins.core.units import ARCSEC, DEG, DPH, UG
from inins.scenario.base import ScenarioModel, ScenarioPath
from inins.scenario.base import ScenarioSection as Section
from inins.scenario.common import Site
from inins.scenario.types import NonNegFloat, PositiveFloat
from inins.scenario.validation import KeyPathError

ModelName = Literal["align12", "align10", "nav15", "ekf17", "ekf26"]
MeasurementKind = Literal["velocity", "position", "dd_phase", "pseudorange", "range_rate"]


class Measurement(Section):
    """One aiding measurement: a block of rows added at every update."""

    kind: MeasurementKind = Field(
        description="velocity (NED, m/s), position (NED, m), dd_phase (double-differenced "
        "carrier phase per antenna baseline, m), pseudorange (m) or range_rate (m/s) per "
        "satellite"
    )
    sigma: PositiveFloat = Field(
        description="1-sigma of each row in the measurement's SI unit (m/s for velocity and "
        "range_rate, m otherwise)"
    )
    baseline_b_m: tuple[float, float, float] | None = Field(
        None, description="dd_phase: antenna B minus antenna A in the body frame (m)"
    )
    lever_arm_b_m: tuple[float, float, float] = Field(
        (0.0, 0.0, 0.0),
        description="pseudorange, range_rate: antenna minus IMU in the body frame (m)",
    )
    reference: int = Field(
        0, ge=0, description="dd_phase: index of the reference satellite in satellites (1)"
    )

    @model_validator(mode="after")
    def _baseline(self):
        if self.kind == "dd_phase" and not any(self.baseline_b_m or ()):
            raise KeyPathError(
                ("baseline_b_m",), "a dd_phase measurement needs a baseline of non-zero length"
            )
        return self


class Satellite(Section):
    """A satellite direction seen from the receiver (the same for every segment)."""

    azimuth_deg: float = Field(description="azimuth, clockwise from north (deg)")
    elevation_deg: float = Field(ge=-90.0, le=90.0, description="elevation (deg)")


class Segment(Section):
    """One piecewise-constant operating point."""

    duration_s: PositiveFloat = Field(description="time held (s)")
    heading_deg: float = Field(0.0, description="heading, clockwise from north (deg)")
    roll_deg: float = Field(0.0, description="roll (deg)")
    pitch_deg: float = Field(0.0, description="pitch (deg)")
    speed_mps: float | None = Field(
        None, description="ground speed along the heading (m/s); or give vel_n_mps"
    )
    vel_n_mps: tuple[float, float, float] | None = Field(
        None, description="NED velocity (m/s); default 0 (or speed_mps along the heading)"
    )
    f_b_mps2: tuple[float, float, float] | None = Field(
        None, description="specific force in the body frame (m/s^2); default unaccelerated"
    )
    omega_b_dps: tuple[float, float, float] | None = Field(
        None,
        description="body angular rate relative to the navigation frame (deg/s); "
        "default 0 (the Earth and transport rates are added)",
    )

    @model_validator(mode="after")
    def _one_velocity(self):
        if self.speed_mps is not None and self.vel_n_mps is not None:
            raise KeyPathError(("speed_mps",), "give speed_mps or vel_n_mps, not both")
        return self


class Trajectory(Section):
    """Segments cut from a trajectory file instead of listed ones."""

    file: ScenarioPath = Field(
        description="table-data HDF5 written by simulate-table (its truth attitude and "
        "IMU increments), relative to this scenario file"
    )
    attitude_threshold_deg: PositiveFloat = Field(
        2.0, description="a new segment starts when the attitude has turned this far (deg)"
    )
    force_threshold_mps2: PositiveFloat = Field(
        0.5, description="... or the body specific force has changed this much (m/s^2)"
    )


class FlightSource(Section):
    """Segments cut from the simulated flight of a run-ekf scenario (its ``flight:``
    legs: ground wait, take-off, climbs, straight legs, bank turns)."""

    scenario: ScenarioPath = Field(
        description="a run-ekf scenario with a flight: section (e.g. "
        "configs/paper003/ekf2-fb.yaml), relative to this scenario file"
    )
    sample_rate_hz: PositiveFloat = Field(
        1.0, description="rate the flight's attitude and specific force are sampled at (Hz)"
    )
    attitude_threshold_deg: PositiveFloat = Field(
        5.0, description="a new segment starts when the attitude has turned this far (deg)"
    )
    force_threshold_mps2: PositiveFloat = Field(
        0.5, description="... or the body specific force has changed this much (m/s^2)"
    )


class Priors(Section):
    """Initial 1-sigma per state group for the covariance analysis (absent groups: not
    in the model, or left at the default)."""

    position_m: PositiveFloat = Field(10.0, description="position, each axis (m)")
    velocity_mps: PositiveFloat = Field(0.5, description="velocity, each axis (m/s)")
    attitude_deg: PositiveFloat = Field(1.0, description="attitude, each axis (deg)")
    accel_bias_ug: PositiveFloat = Field(1000.0, description="accelerometer bias (ug)")
    gyro_bias_dph: PositiveFloat = Field(1.0, description="gyro bias (deg/h)")
    accel_misalignment_arcsec: PositiveFloat = Field(
        60.0, description="accelerometer misalignment (arcsec)"
    )
    gyro_misalignment_arcsec: PositiveFloat = Field(60.0, description="gyro misalignment (arcsec)")
    clock_bias_m: PositiveFloat = Field(100.0, description="receiver clock bias (m)")
    clock_drift_mps: PositiveFloat = Field(1.0, description="receiver clock drift (m/s)")

    def sigmas(self, names):
        """Initial 1-sigma per state of ``names`` in SI, shape (n,)."""
        group_of = {name: group for group, members in GROUPS.items() for name in members}
        out = []
        for name in names:
            if name == "clock_bias":
                out.append(self.clock_bias_m)
            elif name == "clock_drift":
                out.append(self.clock_drift_mps)
            else:
                key, unit = _PRIOR_OF_GROUP[group_of[name]]
                out.append(getattr(self, key) * unit)
        return np.array(out)


_PRIOR_OF_GROUP = {  # state group -> (prior key, SI per unit)
    "position": ("position_m", 1.0),
    "velocity": ("velocity_mps", 1.0),
    "attitude": ("attitude_deg", DEG),
    "accel_bias": ("accel_bias_ug", UG),
    "gyro_bias": ("gyro_bias_dph", DPH),
    "accel_misalignment": ("accel_misalignment_arcsec", ARCSEC),
    "gyro_misalignment": ("gyro_misalignment_arcsec", ARCSEC),
}


class Noise(Section):
    """Process noise of the covariance analysis."""

    arw_deg_rth: NonNegFloat = Field(0.0, description="gyro angle random walk (deg/sqrt(h))")
    vrw_ug_rthz: NonNegFloat = Field(
        0.0, description="accelerometer velocity random walk (ug/sqrt(Hz))"
    )


class ObservabilityScenario(ScenarioModel):
    """Observability of an INS error-state model along piecewise-constant segments."""

    model: ModelName = Field(
        "align12",
        description="error-state model: align12 (002 in-flight alignment: dv, phi, accel "
        "and gyro bias), align10 (classic stationary: horizontal dv, phi, accel and gyro "
        "bias), nav15, ekf17 (+ clock), ekf26 (+ accel and gyro misalignment)",
    )
    site: Site = Field(default_factory=Site)
    measurements: list[Measurement] = Field(min_length=1, description="aiding measurements")
    satellites: list[Satellite] = Field(
        [], description="satellite directions for dd_phase, pseudorange and range_rate rows"
    )
    segments: list[Segment] = Field(
        [], description="the manoeuvre, in order; give this or trajectory"
    )
    trajectory: Trajectory | None = Field(
        None, description="cut the segments from a trajectory file instead"
    )
    flight: FlightSource | None = Field(
        None, description="cut the segments from a run-ekf scenario's simulated flight instead"
    )
    update_interval_s: PositiveFloat = Field(
        1.0, description="measurement interval of the covariance analysis (s)"
    )
    priors: Priors = Field(default_factory=Priors)
    noise: Noise = Field(default_factory=Noise)
    covariance: bool = Field(True, description="also run the covariance analysis (1)")

    def lines_of_sight(self):
        """Unit vectors receiver -> satellite in NED, shape (k, 3), or None."""
        if not self.satellites:
            return None
        az = np.array([s.azimuth_deg for s in self.satellites]) * DEG
        el = np.array([s.elevation_deg for s in self.satellites]) * DEG
        return np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), -np.sin(el)], axis=1)

    @model_validator(mode="after")
    def _sources(self):
        sources = [bool(self.segments), self.trajectory is not None, self.flight is not None]
        if sum(sources) != 1:
            raise KeyPathError(
                ("segments",),
                "give exactly one of segments, trajectory (a file) and flight (a run-ekf scenario)",
            )
        needs_sky = [
            i for i, m in enumerate(self.measurements) if m.kind not in ("velocity", "position")
        ]
        if needs_sky and not self.satellites:
            i = needs_sky[0]
            raise KeyPathError(
                ("measurements", i, "kind"),
                f"a {self.measurements[i].kind} measurement needs satellites",
            )
        for i, m in enumerate(self.measurements):
            if m.kind == "dd_phase" and m.reference >= len(self.satellites):
                raise KeyPathError(
                    ("measurements", i, "reference"),
                    f"there are {len(self.satellites)} satellites",
                )
        return self
