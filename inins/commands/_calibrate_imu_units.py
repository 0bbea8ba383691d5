"""calibrate-imu's lab units of every term and the result-name prefix of every method
(shared by the command and its figures)."""

from inins.calibration import imu_model
from inins.core.units import ARCSEC, DPH, G0, PPM, UG

PREFIX = {"discrete": "discrete", "table-free": "table_free", "system-level": "system"}

# term group -> (lab unit suffix, SI per lab unit)
LAB = {
    "accel_bias": ("ug", UG),
    "gyro_bias": ("dph", DPH),
    "accel_scale": ("ppm", PPM),
    "gyro_scale": ("ppm", PPM),
    "accel_misalignment": ("arcsec", ARCSEC),
    "gyro_misalignment": ("arcsec", ARCSEC),
    "gyro_g_sensitivity": ("dph_per_g", DPH / G0),
    "mount": ("arcsec", ARCSEC),
}


def lab(name):
    """``(unit suffix, SI per unit)`` of a term."""
    return LAB[imu_model.GROUP_OF[name]]
