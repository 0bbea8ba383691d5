"""Scenario sections shared by several commands: site, IMU sensor errors.

Lab units live here and only here: every key carries its unit as a suffix and
each section converts itself to the SI objects of the core (``to_si``).
"""

import numpy as np
from pydantic import Field, model_validator

from inins.core import imu
from inins.core.units import ARCSEC, DEG, DEG_RTH, DPH, PPM, UG, UG_RTHZ, UG_S
from inins.scenario.base import ScenarioSection as Section
from inins.scenario.types import NonNegVec3, PositiveFloat, Vec3


def _all_or_none(weights, name):
    if 0.0 in weights and any(w > 0.0 for w in weights):
        raise ValueError(f"{name}: quantize all three axes or none (got {list(weights)})")


class Site(Section):
    """Where the IMU is: geodetic position on WGS84."""

    lat_deg: float = Field(37.0, ge=-90, le=90, description="geodetic latitude (deg)")
    lon_deg: float = Field(127.0, ge=-180, le=360, description="longitude (deg)")
    height_m: float = Field(50.0, ge=-1000, le=1e5, description="height above the ellipsoid (m)")

    def lla(self):
        """``[lat rad, lon rad, height m]``."""
        return np.array([self.lat_deg * DEG, self.lon_deg * DEG, self.height_m])


class GyroMisalignment(Section):
    """Gyro misalignments beta_ij: gyro i tilted toward body axis j (arcsec)."""

    xy: float = Field(0.0, description="gyro x toward y (arcsec)")
    xz: float = Field(0.0, description="gyro x toward z (arcsec)")
    yx: float = Field(0.0, description="gyro y toward x (arcsec)")
    yz: float = Field(0.0, description="gyro y toward z (arcsec)")
    zx: float = Field(0.0, description="gyro z toward x (arcsec)")
    zy: float = Field(0.0, description="gyro z toward y (arcsec)")


class AccelMisalignment(Section):
    """Accelerometer misalignments alpha_ij (arcsec); xy, xz, yz are zero by the b-frame
    definition (package docstring)."""

    yx: float = Field(0.0, description="accel y toward x (arcsec)")
    zx: float = Field(0.0, description="accel z toward x (arcsec)")
    zy: float = Field(0.0, description="accel z toward y (arcsec)")


class Gyro(Section):
    """Gyro triad errors (000 eq. 2, 003 eq. 2)."""

    bias_dph: Vec3 = Field(0.0, description="constant bias per axis (deg/h)")
    scale_ppm: Vec3 = Field(0.0, description="scale-factor error per axis (ppm)")
    misalignment_arcsec: GyroMisalignment = Field(default_factory=GyroMisalignment)
    arw_deg_rth: NonNegVec3 = Field(0.0, description="angle random walk (deg/sqrt(h))")
    bias_instability_dph: NonNegVec3 = Field(
        0.0, description="Gauss-Markov bias instability, 1 sigma (deg/h)"
    )
    bias_corr_time_s: PositiveFloat = Field(
        3600.0, description="correlation time of the bias instability (s)"
    )
    temp_sensitivity_dph_per_degc: Vec3 = Field(
        0.0, description="bias change per degree of temperature offset (deg/h/degC)"
    )
    pulse_weight_arcsec: NonNegVec3 = Field(
        0.0, description="angle per output pulse (arcsec); 0 = no quantization"
    )

    @model_validator(mode="after")
    def _pulse_weights(self):
        _all_or_none(self.pulse_weight_arcsec, "pulse_weight_arcsec")
        return self


class Accel(Section):
    """Accelerometer triad errors (000 eq. 2, 003 eq. 3)."""

    bias_ug: Vec3 = Field(0.0, description="constant bias per axis (ug)")
    scale_ppm: Vec3 = Field(0.0, description="scale-factor error per axis (ppm)")
    misalignment_arcsec: AccelMisalignment = Field(default_factory=AccelMisalignment)
    vrw_ug_rthz: NonNegVec3 = Field(0.0, description="velocity random walk (ug/sqrt(Hz))")
    bias_instability_ug: NonNegVec3 = Field(
        0.0, description="Gauss-Markov bias instability, 1 sigma (ug)"
    )
    bias_corr_time_s: PositiveFloat = Field(
        3600.0, description="correlation time of the bias instability (s)"
    )
    temp_sensitivity_ug_per_degc: Vec3 = Field(
        0.0,
        description="bias change per degree of temperature offset (ug/degC); "
        "000 §2 quotes ~10 ug/degC for a QA-2000",
    )
    pulse_weight_ug_s: NonNegVec3 = Field(
        0.0, description="velocity per output pulse (ug*s); 0 = no quantization"
    )

    @model_validator(mode="after")
    def _pulse_weights(self):
        _all_or_none(self.pulse_weight_ug_s, "pulse_weight_ug_s")
        return self


class Imu(Section):
    """The IMU: sample rate and sensor error model."""

    sample_rate_hz: PositiveFloat = Field(1000.0, description="increment output rate (Hz)")
    gyro: Gyro = Field(default_factory=Gyro)
    accel: Accel = Field(default_factory=Accel)

    def to_si(self):
        """The sensor error model in SI (:class:`inins.core.imu.SensorErrors`)."""
        g, a = self.gyro, self.accel
        gm, am = g.misalignment_arcsec, a.misalignment_arcsec
        return imu.SensorErrors(
            gyro_bias=np.array(g.bias_dph) * DPH,
            gyro_scale=np.array(g.scale_ppm) * PPM,
            gyro_misalignment=np.array([gm.xy, gm.xz, gm.yx, gm.yz, gm.zx, gm.zy]) * ARCSEC,
            gyro_arw=np.array(g.arw_deg_rth) * DEG_RTH,
            gyro_bias_instability=np.array(g.bias_instability_dph) * DPH,
            gyro_bias_corr_time_s=g.bias_corr_time_s,
            gyro_temp_sensitivity=np.array(g.temp_sensitivity_dph_per_degc) * DPH,
            gyro_pulse_weight=np.array(g.pulse_weight_arcsec) * ARCSEC,
            accel_bias=np.array(a.bias_ug) * UG,
            accel_scale=np.array(a.scale_ppm) * PPM,
            accel_misalignment=np.array([am.yx, am.zx, am.zy]) * ARCSEC,
            accel_vrw=np.array(a.vrw_ug_rthz) * UG_RTHZ,
            accel_bias_instability=np.array(a.bias_instability_ug) * UG,
            accel_bias_corr_time_s=a.bias_corr_time_s,
            accel_temp_sensitivity=np.array(a.temp_sensitivity_ug_per_degc) * UG,
            accel_pulse_weight=np.array(a.pulse_weight_ug_s) * UG_S,
        )
