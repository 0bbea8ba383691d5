"""Stationary alignment against closed forms on exact increments."""

import numpy as np
import pytest

from inins.calibration import alignment
from inins.core import earth, error_model, rotation, trajectory
from inins.core.units import ARCSEC, DEG, DPH, UG

LAT = 45.0 * DEG


def window(mat_nb, seconds=300.0, rate=100.0, gyro_bias=0.0, accel_bias=0.0):
    truth = trajectory.Stationary(LAT, 0.1, 100.0, mat_nb)
    edges = np.arange(int(seconds * rate) + 1) / rate
    dtheta, dv = trajectory.ideal_increments(truth, edges, nodes=1, chunk=edges.size)
    return dtheta + np.asarray(gyro_bias) / rate, dv + np.asarray(accel_bias) / rate, 1 / rate


@pytest.mark.parametrize(
    "euler_deg", [(1.0, -2.0, 30.0), (0.3, 0.2, 275.0), (180.0, 0.5, 90.0)]
)  # the last: z axis up
def test_error_free_alignment_is_exact(euler_deg):
    mat_nb = rotation.mat_from_euler(*np.radians(euler_deg))
    dtheta, dv, dt = window(mat_nb)
    result = alignment.align_stationary(dtheta, dv, dt, LAT)
    assert np.abs(error_model.attitude_error(result.mat_nb, mat_nb)).max() < 1e-4 * ARCSEC


def test_heading_error_is_east_gyro_bias_over_horizontal_earth_rate():
    mat_nb = rotation.mat_from_euler(0.0, 0.0, 0.0)  # x north, y east
    eps_east = 0.01 * DPH
    dtheta, dv, dt = window(mat_nb, gyro_bias=[0.0, eps_east, 0.0])
    result = alignment.align_stationary(dtheta, dv, dt, LAT)
    phi = error_model.attitude_error(result.mat_nb, mat_nb)
    # 000 §3.1: 0.01 deg/h at 45 deg latitude -> 0.054 deg
    assert abs(phi[2]) == pytest.approx(eps_east / (earth.RATE * np.cos(LAT)), rel=1e-3)
    assert np.degrees(abs(phi[2])) == pytest.approx(0.0539, abs=1e-4)


def test_tilt_error_is_accel_bias_over_g():
    mat_nb = rotation.mat_from_euler(0.0, 0.0, 0.0)
    dtheta, dv, dt = window(mat_nb, accel_bias=[100 * UG, 0.0, 0.0])
    result = alignment.align_stationary(dtheta, dv, dt, LAT)
    phi = error_model.attitude_error(result.mat_nb, mat_nb)
    g = earth.gravity(LAT, 100.0)
    assert abs(phi[1]) == pytest.approx(100 * UG / g, rel=1e-3)


def test_earth_rate_check_recovers_latitude():
    mat_nb = rotation.mat_from_euler(0.2, -0.1, 2.0)
    dtheta, dv, dt = window(mat_nb)
    rate, lat, horizontal = alignment.earth_rate_check(*alignment.mean_rates(dtheta, dv, dt))
    assert rate == pytest.approx(earth.RATE, rel=1e-12)
    assert lat == pytest.approx(LAT, abs=1e-12)
    assert horizontal == pytest.approx(earth.RATE * np.cos(LAT), rel=1e-12)


def test_known_heading_and_noise_figures():
    mat_nb = rotation.mat_from_euler(0.0, 0.0, 1.0)
    dtheta, dv, dt = window(mat_nb, seconds=400.0)
    arw = 0.001 * DEG / 60.0
    result = alignment.align_stationary(dtheta, dv, dt, LAT, heading=1.0, arw=arw)
    assert result.method == "known heading" and result.heading_sigma == 0.0
    result = alignment.align_stationary(dtheta, dv, dt, LAT, arw=arw)
    assert result.heading_sigma == pytest.approx(arw / (earth.RATE * np.cos(LAT) * 20.0))
