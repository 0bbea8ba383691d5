"""A compensation file (``inins calibrate-imu``'s output, validated) in SI terms
(:class:`inins.calibration.imu_model.ImuTerms`)."""

import numpy as np

from inins.calibration import imu_model
from inins.core.units import ARCSEC, DPH, G0, PPM, UG
from inins.exceptions import InputError


def terms_from_compensation(comp):
    """:class:`~inins.calibration.imu_model.ImuTerms` (SI) of a validated
    :class:`~inins.scenario.calibrate_imu.CompensationFile`."""
    c = comp.imu
    values = {}
    for i, a in enumerate("xyz"):
        values[f"bg_{a}"] = c.gyro_bias_dph[i] * DPH
        values[f"sg_{a}"] = c.gyro_scale_ppm[i] * PPM
        values[f"ba_{a}"] = c.accel_bias_ug[i] * UG
        values[f"sa_{a}"] = c.accel_scale_ppm[i] * PPM
    for k, v in c.gyro_misalignment_arcsec.items():
        values[f"mg_{k}"] = v * ARCSEC
    for k, v in c.accel_misalignment_arcsec.items():
        values[f"ma_{k}"] = v * ARCSEC
    if c.gyro_g_sensitivity_dph_per_g is not None:
        mat = np.asarray(c.gyro_g_sensitivity_dph_per_g, float)
        if mat.shape != (3, 3):
            raise InputError("needs 3 rows of 3 numbers", key="imu.gyro_g_sensitivity_dph_per_g")
        values.update(zip(imu_model.G_SENS_TERMS, mat.ravel() * DPH / G0, strict=True))
    return imu_model.ImuTerms(values)
