"""A calibrate-bias scenario's method settings in SI (:class:`inins.calibration.bias.Settings`)."""

import numpy as np

from inins.calibration import bias, budget
from inins.core.units import ARCSEC, DEG, DEG_RTH, DPH, PPM, UG, UG_RTHZ, UG_S


def method_settings(scenario, sensor=None, ett_result=None):
    """The method settings in SI; ``sensor`` (SensorErrors of a simulation) fills the
    noise figures the scenario leaves out; ``ett_result`` is the ETT mounting."""
    n = scenario.noise
    arw = n.arw_deg_rth and [a * DEG_RTH for a in n.arw_deg_rth]
    if arw is None and sensor is not None:
        arw = sensor.gyro_arw
    vrw = (
        n.vrw_ug_rthz * UG_RTHZ
        if n.vrw_ug_rthz is not None
        else sensor.accel_vrw
        if sensor is not None
        else None
    )
    quantum = (
        n.accel_pulse_weight_ug_s * UG_S
        if n.accel_pulse_weight_ug_s is not None
        else float(sensor.accel_pulse_weight.mean())
        if sensor is not None
        else 0.0
    )
    a = scenario.alignment
    return bias.Settings(
        align_duration=a.duration_s,
        heading=None if a.heading_deg is None else a.heading_deg * DEG,
        heading_method=bias.HeadingMethod(a.method),
        heading_sigma=a.heading_sigma_arcsec * ARCSEC,
        epoch_window=scenario.sequence.epoch_window_s,
        settle=scenario.sequence.settle_s,
        labels=None if scenario.sequence.labels is None else tuple(scenario.sequence.labels),
        output_rate=scenario.navigation.output_rate_hz,
        free=scenario.navigation.mode == "free",
        arw=arw,
        vrw=vrw,
        accel_quantum=quantum,
        bias_z=scenario.gyro_bias_z_dph * DPH,
        k_sigma=scenario.mount_detection.k_sigma,
        floor=scenario.mount_detection.floor_arcsec * ARCSEC,
        ett=ett_result,
        bias_bound=_bias_bound(scenario, sensor),
        stated=_stated(scenario.uncertainty),
    )


def _stated(u):
    """The scenario's stated 1-sigma sensor errors in SI."""
    return budget.StatedErrors(
        accel_bias=u.accel_bias_ug * UG,
        gyro_bias_z=u.gyro_bias_z_dph * DPH,
        gyro_scale=np.broadcast_to(np.asarray(u.gyro_scale_ppm, float) * PPM, (3,)).copy(),
        gyro_misalignment=np.full(6, u.gyro_misalignment_arcsec * ARCSEC),
        bias_instability=u.gyro_bias_instability_dph * DPH,
        corr_time=u.gyro_bias_corr_time_s,
    )


def _bias_bound(scenario, sensor):
    """Largest gyro bias (rad/s) for the gyrocompass check: the scenario's stated bound,
    else the simulated bias (its magnitude), else None (checked on the estimates)."""
    stated = scenario.alignment.gyro_bias_bound_dph
    if stated is not None:
        return stated * DPH
    if sensor is not None:
        return float(np.linalg.norm(sensor.gyro_bias))
    return None
