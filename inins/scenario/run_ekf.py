"""Scenario of ``inins run-ekf`` (spec §6, §6a, paper 003): a simulated flight
(``flight:`` + ``gnss:``) or a recording (``data:``), and the filter (``filter:``).

Simulated: legs flown from a ground wait aligned by gyrocompass at the site, 200 Hz
increments through the sensor error model with RLG dither, 1 Hz pseudoranges and
range rates of a constellation (the shipped ABPO navigation file at a chosen GPS
time, or a Walker constellation) with a TCXO clock, lever arm and latency.
Recorded: an import-flight output (``.h5``) or the PSINS tc ``.mat`` file directly.
"""

import math
from typing import Literal

from pydantic import Field, model_validator

from inins.core import flight as core_flight
from inins.core.units import ARCSEC, DEG, DEG_RTH, DPH, UG, UG_RTHZ
from inins.exceptions import InputError
from inins.scenario.base import InputFile, ScenarioModel, ScenarioPath
from inins.scenario.base import ScenarioSection as Section
from inins.scenario.common import Imu, Site
from inins.scenario.run_ekf_post import PostProcess
from inins.scenario.types import LeverArm, NonNegFloat, PositiveFloat, Sigma
from inins.scenario.validation import KeyPathError

LegKindName = Literal["wait", "takeoff", "climb", "descend", "straight", "turn"]


class FlightLeg(Section):
    """One leg of the flight plan."""

    kind: LegKindName = Field(
        description="wait (on the ground), takeoff (accelerate to speed_mps), climb / descend "
        "(at climb_rate_mps), straight, turn (coordinated bank turn)"
    )
    duration_s: float = Field(
        0.0, description="leg length (s); a turn may give 0: as long as its angle needs"
    )
    speed_mps: PositiveFloat | None = Field(
        None, description="ground speed to reach (m/s): takeoff needs it; else a speed change"
    )
    climb_rate_mps: NonNegFloat = Field(
        0.0, description="climb / descend: vertical speed (m/s), the kind gives the sign"
    )
    bank_deg: float = Field(0.0, description="turn: bank angle (deg), in (0, 90)")
    angle_deg: PositiveFloat = Field(360.0, description="turn: heading change (deg)")
    direction: Literal["right", "left"] = Field("right", description="turn: direction")
    turn_rate_dps: PositiveFloat | None = Field(
        None,
        description="turn: stated turn rate (deg/s), checked against the coordinated "
        "g tan(bank) / V (5 %); default the coordinated rate",
    )


class Dither(Section):
    """RLG mechanical dither of the sensor block (003 §2.2)."""

    amplitude_arcsec: NonNegFloat = Field(60.0, description="peak dither angle (arcsec)")
    frequency_hz: PositiveFloat = Field(40.0, description="dither frequency (Hz)")


class Flight(Section):
    """The simulated flight: site, ground heading, legs, IMU and dither."""

    site: Site = Field(default_factory=Site)
    heading_deg: float = Field(180.0, description="heading on the ground (deg), 180 in 003")
    aoa_deg: float = Field(2.0, ge=-20.0, le=20.0, description="angle of attack (deg)")
    legs: list[FlightLeg] = Field(min_length=1, description="the flight plan, in order")
    imu: Imu = Field(default_factory=lambda: Imu(sample_rate_hz=200.0))
    dither: Dither = Field(default_factory=Dither)

    def plan(self):
        """The flight plan in SI (:class:`inins.core.flight.FlightPlan`), validated there;
        an impossible leg names its scenario key (``flight.legs[2].bank_deg``)."""
        kinds = core_flight.LegKind
        legs = []
        for leg in self.legs:
            speed = math.nan if leg.speed_mps is None else leg.speed_mps
            if leg.kind in ("climb", "descend"):
                rate = leg.climb_rate_mps if leg.kind == "climb" else -leg.climb_rate_mps
                legs.append(core_flight.Leg(kinds.CLIMB, leg.duration_s, speed, climb_rate=rate))
            elif leg.kind == "turn":
                sign = 1.0 if leg.direction == "right" else -1.0
                rate = math.nan if leg.turn_rate_dps is None else leg.turn_rate_dps * DEG
                legs.append(
                    core_flight.Leg(
                        kinds.TURN,
                        leg.duration_s,
                        speed,
                        bank=leg.bank_deg * DEG,
                        angle=sign * leg.angle_deg * DEG,
                        turn_rate=rate,
                    )
                )
            else:
                legs.append(core_flight.Leg(kinds(leg.kind), leg.duration_s, speed))
        lla = self.site.lla()
        plan = core_flight.FlightPlan(
            lla[0], lla[1], lla[2], self.heading_deg * DEG, tuple(legs), aoa=self.aoa_deg * DEG
        )
        try:
            _ = plan.duration
        except InputError as exc:
            raise InputError(str(exc.args[0]), key=_leg_key(exc.key)) from None
        return plan


_LEG_FIELDS = {
    "duration": "duration_s",
    "speed": "speed_mps",
    "climb_rate": "climb_rate_mps",
    "bank": "bank_deg",
    "angle": "angle_deg",
    "turn_rate": "turn_rate_dps",
}


def _leg_key(key):
    """``legs.2.bank`` (flight-plan key) -> ``flight.legs[2].bank_deg`` (scenario key)."""
    parts = (key or "").split(".")
    if len(parts) == 3 and parts[0] == "legs":
        return f"flight.legs[{parts[1]}].{_LEG_FIELDS.get(parts[2], parts[2])}"
    return f"flight.{key}"


class Constellation(Section):
    """Where the satellites come from."""

    source: Literal["abpo", "walker", "mixed"] = Field(
        "abpo",
        description="abpo: the shipped broadcast navigation file data/abpo0080.15n.gz "
        "(2015-01-08); walker: a nominal Walker 55 deg constellation; mixed: GPS, GLONASS, "
        "Galileo and BeiDou of the shipped smartLoc mixed RINEX 3 file (2016-06-06; its "
        "Galileo and BeiDou sets span about 09:00-23:00: at Berlin start_hour_s 64800 sees "
        "2 and 3 of them, 21600 none; inter-system biases from gnss.system_bias_m)",
    )
    start_hour_s: NonNegFloat = Field(
        21600.0,
        lt=86400.0,
        description="GPS time of IMU t = 0: seconds into 2015-01-08 (2016-06-06 for mixed) (s)",
    )
    per_plane: int = Field(5, ge=4, le=8, description="walker: satellites per plane (1)")


class Gnss(Section):
    """The simulated receiver."""

    constellation: Constellation = Field(default_factory=Constellation)
    mask_deg: float = Field(10.0, ge=-5.0, le=90.0, description="elevation mask (deg)")
    pseudorange_sigma_m: PositiveFloat = Field(
        2.0, le=100.0, description="pseudorange white noise (m)"
    )
    range_rate_sigma_mps: PositiveFloat = Field(
        0.05, le=10.0, description="range-rate white noise (m/s)"
    )
    clock_h0_s: NonNegFloat = Field(
        2e-19, le=1e-15, description="TCXO white frequency noise h0 (s)"
    )
    clock_hm2_per_s: NonNegFloat = Field(
        2e-20, le=1e-15, description="TCXO random-walk frequency noise h-2 (1/s)"
    )
    clock_bias_m: float = Field(3000.0, description="receiver clock bias at t = 0 (m)")
    clock_drift_mps: float = Field(0.5, description="receiver clock drift at t = 0 (m/s)")
    lever_arm_m: LeverArm = Field(
        (1.5, 0.2, -1.0), description="antenna minus IMU, body axes (m), each within 100 m"
    )
    latency_s: NonNegFloat = Field(
        0.15, le=0.9, description="data arrival after the 1PPS epoch (s)"
    )
    system_bias_m: dict[Literal["G", "R", "E", "C"], float] = Field(
        default_factory=dict,
        description="inter-system bias the receiver adds to a system's pseudoranges, by "
        "RINEX letter (m), constant, e.g. {R: 30}: the GLONASS-GPS time offset and the "
        "receiver's code biases; the filter estimates each against its first system",
    )

    glonass_ifb_m_per_channel: float = Field(
        0.0,
        ge=-2.0,
        le=2.0,
        description="GLONASS inter-frequency code bias: k times this on the pseudoranges of "
        "frequency channel k (m per channel); the filter's one GLONASS bias takes its "
        "mean, the rest stays in the residuals",
    )

    def receiver_si(self):
        """The simulated receiver in SI: keywords of :class:`inins.ekf.sources.Receiver`
        but the filter's sigmas (which the ``filter:`` section gives)."""
        return {
            "lever_arm": tuple(self.lever_arm_m),
            "mask": self.mask_deg * DEG,
            "sigma_pr": self.pseudorange_sigma_m,
            "sigma_rr": self.range_rate_sigma_mps,
            "h0": self.clock_h0_s,
            "h_2": self.clock_hm2_per_s,
            "clock_bias": self.clock_bias_m,
            "clock_drift": self.clock_drift_mps,
            "latency": self.latency_s,
            "glonass_ifb": self.glonass_ifb_m_per_channel,
            "system_bias": tuple(
                ("GREC".index(k), float(v)) for k, v in sorted(self.system_bias_m.items())
            ),
        }


class Data(Section):
    """A recording instead of a simulation."""

    file: ScenarioPath = Field(
        description="import-flight output (.h5, recorded-flight layout) or the PSINS tc "
        ".mat file, relative to this scenario file"
    )
    static_window_s: tuple[float, float] = Field(
        description="IMU time (s) where the vehicle stands: levelling"
    )
    motion_speed_mps: PositiveFloat = Field(
        1.5, description="SPP ground speed (m/s) above which the motion gives the heading"
    )
    forward_axis_b: tuple[float, float, float] = Field(
        (1.0, 0.0, 0.0),
        description="body axis the vehicle moves along (unit vector, body axes; 1), for "
        "the heading reported against the track",
    )
    lever_arm_m: LeverArm = Field(
        (0.0, 0.0, 0.0), description="antenna minus IMU, body axes (m), each within 100 m"
    )
    latency_s: NonNegFloat = Field(0.0, le=0.9, description="data arrival after the epoch (s)")
    mask_deg: float = Field(10.0, ge=-5.0, le=90.0, description="elevation mask (deg)")

    @model_validator(mode="after")
    def _window(self):
        if not self.static_window_s[1] > self.static_window_s[0] + 5.0:
            raise KeyPathError(("static_window_s",), "needs end > start + 5 s")
        return self


class InitialSigma(Section):
    """Initial 1-sigma of the error states."""

    position_m: Sigma(1e-4, 1e5) = Field(5.0, description="position, each axis (m)")
    velocity_mps: Sigma(1e-4, 1e3) = Field(0.1, description="velocity, each axis (m/s)")
    tilt_deg: Sigma(1e-6, 90.0) = Field(0.01, description="roll and pitch error (deg)")
    heading_deg: Sigma(1e-6, 180.0) = Field(0.1, description="heading error (deg)")
    accel_bias_ug: Sigma(1e-3, 1e6) = Field(100.0, description="accelerometer bias (ug)")
    gyro_bias_dph: Sigma(1e-6, 1e5) = Field(0.02, description="gyro bias (deg/h)")
    accel_misalignment_arcsec: Sigma(1e-3, 1e5) = Field(
        20.0, description="accelerometer misalignment (arcsec)"
    )
    gyro_misalignment_arcsec: Sigma(1e-3, 1e5) = Field(
        60.0, description="gyro misalignment (arcsec)"
    )
    clock_bias_m: Sigma(1e-3, 1e8) = Field(1e4, description="receiver clock bias (m)")
    clock_drift_mps: Sigma(1e-4, 1e5) = Field(10.0, description="receiver clock drift (m/s)")
    system_bias_m: Sigma(1e-3, 1e6) = Field(
        100.0, description="each inter-system bias state (m), set first from the residuals"
    )


class FilterNoise(Section):
    """Process noise of the filter."""

    arw_deg_rth: NonNegFloat = Field(
        0.002, le=100.0, description="gyro angle random walk (deg/sqrt(h))"
    )
    vrw_ug_rthz: NonNegFloat = Field(
        20.0, le=1e5, description="accelerometer velocity random walk (ug/sqrt(Hz))"
    )
    gyro_bias_walk_dph: NonNegFloat = Field(
        0.0, le=1e5, description="gyro bias random walk: 1-sigma growth over one hour (deg/h)"
    )
    accel_bias_walk_ug: NonNegFloat = Field(
        0.0, le=1e6, description="accelerometer bias random walk: 1-sigma growth over one hour (ug)"
    )
    clock_h0_s: NonNegFloat = Field(2e-19, le=1e-15, description="clock model h0 (s)")
    clock_hm2_per_s: NonNegFloat = Field(2e-20, le=1e-15, description="clock model h-2 (1/s)")
    system_bias_walk_m: NonNegFloat = Field(
        0.5,
        le=1e3,
        description="inter-system bias random walk: 1-sigma growth over one hour (m); 0: constant",
    )

    @model_validator(mode="after")
    def _some_white_noise(self):
        if self.arw_deg_rth == 0.0 and self.vrw_ug_rthz == 0.0:
            raise KeyPathError(
                ("arw_deg_rth",),
                "the gyro and accelerometer noise are both 0: the filter would trust the "
                "integrated IMU forever and stop taking the GNSS; give the sensor's noise",
            )
        return self


class FilterSettings(Section):
    """The tightly coupled filter (003 §2)."""

    model: Literal["ekf1", "ekf2"] = Field(
        "ekf2", description="ekf1: 17 states; ekf2: + accel (3) and gyro (6) misalignment"
    )
    coupling: Literal["ff", "fb"] = Field(
        "fb", description="ff: corrections at the output; fb: fed back, states reset"
    )
    noise: FilterNoise = Field(default_factory=FilterNoise)
    initial_sigma: InitialSigma = Field(default_factory=InitialSigma)
    pseudorange_sigma_m: PositiveFloat = Field(
        2.0, le=100.0, description="pseudorange 1-sigma the filter uses (m)"
    )
    range_rate_sigma_mps: PositiveFloat = Field(
        0.05, le=10.0, description="range-rate 1-sigma the filter uses (m/s)"
    )
    use_range_rate: bool = Field(True, description="update with the range rates too")
    gate_probability: float = Field(
        0.9999, gt=0.5, le=1.0, description="chi-square(1) gate per measurement (1)"
    )
    dither_window: int | Literal["auto"] = Field(
        "auto",
        description="moving-average length (samples) of f_b, omega_b (003 §2.2); auto: "
        "whole dither periods (1 for recordings)",
    )
    pps_storage: bool = Field(
        True,
        description="update with the INS state stored at the 1PPS (003 §2.1); false: the "
        "naive pairing with the state at the data arrival, whose outputs are then labelled "
        "(nav/time) and scored against truth at the arrival",
    )
    outages_s: list[tuple[float, float]] = Field(
        [], description="GPS outage windows [start, end) (s): epochs inside are coasted"
    )
    turning_from_s: NonNegFloat = Field(
        0.0, description="start of the window of the heading-error RMS (s)"
    )
    smoother: Literal["none", "rts"] = Field(
        "none", description="rts: a Rauch-Tung-Striebel pass over the stored forward run"
    )
    systems: str | None = Field(
        None,
        pattern="^[GREC]+$",
        description="satellite systems the filter takes, RINEX letters (G GPS, R GLONASS, "
        "E Galileo, C BeiDou), e.g. GR: the first of them in the order G R E C carries the "
        "receiver clock, each further "
        "one adds an inter-system bias state (m) after the 17 or 26 states; default: every "
        "system of the constellation or the recording (GPS first)",
    )
    system_sigma_scale: dict[Literal["G", "R", "E", "C"], PositiveFloat] = Field(
        default_factory=dict,
        description="pseudorange 1-sigma of a system's rows as a multiple of "
        "pseudorange_sigma_m, by RINEX letter (1); e.g. {R: 1.5} for GLONASS, whose "
        "inter-frequency biases the one GLONASS bias state leaves in the residuals",
    )

    def to_si(self):
        """Keyword arguments in SI of :class:`inins.ekf.config.FilterConfig` (model and
        coupling as their names, ``initial_sigma`` as the keywords of
        :class:`~inins.ekf.config.InitialSigma`, the clock model as Allan ``clock_h0``
        (s) and ``clock_h_2`` (1/s)); the IMU interval, lever arm and dither window
        come from the flight or the recording."""
        n, s = self.noise, self.initial_sigma
        return {
            "model": self.model,
            "coupling": self.coupling,
            "arw": (n.arw_deg_rth * DEG_RTH,) * 3,
            "vrw": (n.vrw_ug_rthz * UG_RTHZ,) * 3,
            "gyro_bias_rw": (n.gyro_bias_walk_dph * DPH / 60.0,) * 3,  # per sqrt(3600 s)
            "accel_bias_rw": (n.accel_bias_walk_ug * UG / 60.0,) * 3,
            "clock_h0": n.clock_h0_s,
            "clock_h_2": n.clock_hm2_per_s,
            "system_bias_psd": (n.system_bias_walk_m / 60.0) ** 2,  # m^2/s
            "initial_sigma": {
                "position": s.position_m,
                "velocity": s.velocity_mps,
                "tilt": s.tilt_deg * DEG,
                "heading": s.heading_deg * DEG,
                "accel_bias": s.accel_bias_ug * UG,
                "gyro_bias": s.gyro_bias_dph * DPH,
                "accel_misalignment": s.accel_misalignment_arcsec * ARCSEC,
                "gyro_misalignment": s.gyro_misalignment_arcsec * ARCSEC,
                "clock_bias": s.clock_bias_m,
                "clock_drift": s.clock_drift_mps,
                "system_bias": s.system_bias_m,
            },
            "gate_probability": self.gate_probability,
            "outages": tuple(self.outages_s),
            "use_range_rate": self.use_range_rate,
            "pps_storage": self.pps_storage,
        }

    @model_validator(mode="after")
    def _outages(self):
        for i, (a, b) in enumerate(self.outages_s):
            if not b > a:
                raise KeyPathError(("outages_s", i), f"end {b} s not after start {a} s")
        if isinstance(self.dither_window, int) and self.dither_window < 1:
            raise KeyPathError(("dither_window",), "must be >= 1 sample")
        if self.systems is not None and len(set(self.systems)) != len(self.systems):
            raise KeyPathError(("systems",), f"a system given twice in {self.systems!r}")
        return self

    def sigma_scale(self):
        """Factor on the pseudorange sigma per system index (6,) (1 where not given)."""
        out = [1.0] * 6
        for letter, value in self.system_sigma_scale.items():
            out["GREC".index(letter)] = float(value)
        return tuple(out)


class RunEkfScenario(ScenarioModel):
    """Tightly coupled INS/GPS EKF on a simulated flight or a recording."""

    flight: Flight | None = Field(None, description="simulated flight (with gnss)")
    gnss: Gnss | None = Field(None, description="simulated receiver (with flight)")
    data: Data | None = Field(None, description="a recording instead of flight and gnss")
    filter: FilterSettings = Field(default_factory=FilterSettings)
    post: PostProcess | None = Field(
        None, description="post-process a recorded drive loosely coupled (alone)"
    )
    compensation: InputFile | None = Field(
        None,
        description="a compensation file (written by calibrate-imu) applied to the "
        "recorded IMU increments (data, or post's IMU log) before the filter; relative to "
        "this scenario file; not with a simulated flight",
    )
    compensation_serial: str | None = Field(
        None,
        description="serial of the recorded unit: a compensation file made for another "
        "serial is refused",
    )

    @model_validator(mode="after")
    def _one_source(self):
        if self.compensation is not None and self.flight is not None:
            raise KeyPathError(
                ("compensation",), "applies to recorded data (data or post), not a simulated flight"
            )
        if self.post is not None:
            if self.flight is not None or self.gnss is not None or self.data is not None:
                raise KeyPathError(("post",), "post goes alone: no flight, gnss or data")
            return self
        simulated = self.flight is not None or self.gnss is not None
        if simulated == (self.data is not None):
            raise KeyPathError(
                ("data",), "give flight and gnss (simulation) or data (a recording), not both"
            )
        if simulated and (self.flight is None or self.gnss is None):
            key = "flight" if self.flight is None else "gnss"
            raise KeyPathError((key,), "a simulation needs both flight and gnss")
        return self
