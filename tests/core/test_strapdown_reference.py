"""The strapdown kernel against its previous implementation on the same increments.

``strapdown_v0`` is a frozen copy of the kernel before the Earth terms were
computed once per step with shared trigonometry. Removing repeated evaluations of
the same pure functions (sin, cos, tan, sqrt of one latitude) and reading the
state from registers instead of arrays changes no arithmetic: the outputs must be
bit-identical, here on a 1-hour free-navigation flight and on 1-hour stationary
runs in every mode.
"""

import numpy as np
import pytest
import strapdown_v0

from inins.core import error_model, flight, rotation
from inins.core import strapdown as sd
from inins.core import trajectory as tr
from inins.core.units import DEG, DPH, UG

LAT, LON, HEIGHT = 37.0 * DEG, 127.0 * DEG, 300.0


def _hour_flight(rate_hz=100.0):
    """One hour of the default flight plan flown six times in a row, midpoint increments."""
    plan = tuple((t + 600.0 * r, kind, value) for r in range(6)
                 for t, kind, value in flight.FLIGHT_PLAN)
    truth = flight.aircraft_trajectory(velocity=flight.flight_velocity(plan))
    edges = np.arange(int(3600 * rate_hz) + 1) / rate_hz
    dtheta, dv = tr.ideal_increments(truth, edges, nodes=1)
    return truth, dtheta, dv, 1.0 / rate_hz


def _stationary_hour(rate_hz=200.0, seed=3):
    """One hour at rest, tilted, with gyro and accelerometer biases and white noise."""
    dt = 1.0 / rate_hz
    mat_nb = rotation.mat_from_euler(0.02, -0.01, 2.0)
    truth = tr.Stationary(LAT, LON, HEIGHT, mat_nb)
    dtheta, dv = tr.ideal_increments(truth, np.arange(2) * dt)
    n = int(3600 * rate_hz)
    rng = np.random.default_rng(seed)
    dtheta = dtheta + np.array([0.01, -0.02, 0.005]) * DPH * dt + 1e-8 * rng.standard_normal((n, 3))
    dv = dv + np.array([50.0, -30.0, 20.0]) * UG * dt + 1e-6 * rng.standard_normal((n, 3))
    return mat_nb, dtheta, dv, dt


def _both(quat, vel, lla, dtheta, dv, dt, **options):
    """Outputs of the current and the frozen kernel as (index, quat, vel, lla) tuples."""
    state = sd.NavState(quat, vel, lla)
    _, series = sd.integrate(state, dtheta, dv, dt, **options)
    new = (series.index, series.quat_nb, series.vel_n, series.lla)
    old = strapdown_v0.integrate(state.quat_nb, vel, lla, dtheta, dv, dt, **options)
    return new, old


def _assert_identical(new, old):
    for name, a, b in zip(("index", "quat_nb", "vel_n", "lla"), new, old, strict=True):
        assert a.shape == b.shape, name
        assert np.array_equal(a, b), (name, np.abs(a - b).max())


@pytest.fixture(scope="module")
def hour_flight():
    return _hour_flight()


@pytest.mark.slow
def test_hour_flight_free_navigation_is_bit_identical(hour_flight):
    truth, dtheta, dv, dt = hour_flight
    mat_nb, vel_n, lla = truth.state([0.0])
    quat = rotation.quat_from_mat(mat_nb[0])
    new, old = _both(quat, vel_n[0], lla[0], dtheta, dv, dt, decimation=100)
    assert len(new[0]) == 3600
    _assert_identical(new, old)
    # and the run is a real flight: 5.5 deg of longitude, navigated to within metres
    t = (new[0] + 1) * dt
    _, _, lla_true = truth.state(t)
    assert np.degrees(new[3][-1, 1] - new[3][0, 1]) > 3.0
    err = error_model.position_error_ned(new[3], lla_true)
    assert np.abs(err).max() < 50.0  # m; midpoint increments, free vertical channel


@pytest.mark.slow
@pytest.mark.parametrize("options", [{"fixed_position": True},
                                     {"fixed_position": True, "zero_velocity": True},
                                     {"fixed_height": True}, {}],
                         ids=["fixed_position", "zero_velocity", "fixed_height", "free"])
def test_stationary_hour_is_bit_identical(options):
    mat_nb, dtheta, dv, dt = _stationary_hour()
    quat = rotation.quat_from_mat(mat_nb)
    new, old = _both(quat, np.zeros(3), [LAT, LON, HEIGHT], dtheta, dv, dt, decimation=200,
                     **options)
    assert len(new[0]) == 3600
    _assert_identical(new, old)
