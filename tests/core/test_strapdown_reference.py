"""The strapdown kernel against its previous implementation on the same increments.

``strapdown_v0`` is a frozen copy of the kernel before the Earth terms were
computed once per step with shared trigonometry. In fixed-position mode (the
calibration's stationary navigation) the arithmetic is unchanged and the outputs
must be bit-identical. In the free modes the Earth terms changed: ``sin, cos`` of
the mid latitude from a reference latitude on a 2^-10 rad grid by a series
(within 2.3e-16 of libm), ``tan = sin / cos``, the inverse radii ``1 / (R + h)``
with one division each (within 4.5e-16 relative). The bound asked of the outputs
there is 1e-9 of each series' largest magnitude; the measured differences are
far below it (figures at each test).
"""

import math

import numpy as np
import pytest
import strapdown_v0

from inins.core import earth, error_model, flight, rotation
from inins.core import strapdown as sd
from inins.core import trajectory as tr
from inins.core.units import DEG, DPH, UG

LAT, LON, HEIGHT = 37.0 * DEG, 127.0 * DEG, 300.0


def _hour_flight(rate_hz=100.0):
    """One hour of the default flight plan flown six times in a row, midpoint increments."""
    plan = tuple(
        (t + 600.0 * r, kind, value) for r in range(6) for t, kind, value in flight.FLIGHT_PLAN
    )
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


def _differences(new, old):
    """Largest |new - old| of attitude (rad), velocity (m/s), horizontal position (m),
    height (m), after checking the 1e-9 bound relative to each series' largest value."""
    assert np.array_equal(new[0], old[0])
    for a, b in zip(new[1:], old[1:], strict=True):
        scale = np.abs(b).max(axis=0)
        assert np.all(np.abs(a - b).max(axis=0) <= 1e-9 * scale)
    phi = 2.0 * np.abs(new[1] - old[1]).max()  # small-angle attitude difference
    horizontal = np.abs(new[3][:, :2] - old[3][:, :2]).max() * 6.4e6
    return phi, np.abs(new[2] - old[2]).max(), horizontal, np.abs(new[3][:, 2] - old[3][:, 2]).max()


@pytest.fixture(scope="module")
def hour_flight():
    return _hour_flight()


@pytest.mark.slow
@pytest.mark.parametrize(
    "options",
    [{"fixed_position": True}, {"fixed_position": True, "zero_velocity": True}],
    ids=["fixed_position", "zero_velocity"],
)
def test_hour_flight_fixed_position_is_bit_identical(hour_flight, options):
    # the flight's turns and climbs exercise the coning, sculling and rotation terms
    truth, dtheta, dv, dt = hour_flight
    mat_nb, _, lla = truth.state([0.0])
    quat = rotation.quat_from_mat(mat_nb[0])
    _assert_identical(*_both(quat, np.zeros(3), lla[0], dtheta, dv, dt, decimation=100, **options))


@pytest.mark.parametrize(
    "options",
    [{"fixed_position": True}, {"fixed_position": True, "zero_velocity": True}],
    ids=["fixed_position", "zero_velocity"],
)
def test_tumbling_fixed_position_is_bit_identical(options):
    # rotations of ~0.03 rad per sample (series and exact branches of q(r)) and large
    # coning and sculling terms, where the rounding of every correction shows
    rng = np.random.default_rng(7)
    dtheta = 0.02 * rng.standard_normal((100_000, 3))
    dv = 0.05 * rng.standard_normal((100_000, 3))
    _assert_identical(
        *_both(
            [1.0, 0.0, 0.0, 0.0],
            np.zeros(3),
            [LAT, LON, HEIGHT],
            dtheta,
            dv,
            0.01,
            decimation=10,
            **options,
        )
    )


@pytest.mark.slow
def test_hour_flight_free_navigation_matches_previous_kernel(hour_flight):
    truth, dtheta, dv, dt = hour_flight
    mat_nb, vel_n, lla = truth.state([0.0])
    quat = rotation.quat_from_mat(mat_nb[0])
    new, old = _both(quat, vel_n[0], lla[0], dtheta, dv, dt, decimation=100)
    assert len(new[0]) == 3600
    phi, vel, horizontal, height = _differences(new, old)
    # measured 1.8e-14 rad, 1.4e-10 m/s, 9.9e-8 m, 7.7e-8 m after 1 h at up to 150 m/s
    # (the Earth terms of the free modes by cell polynomials, each within a few ulp)
    assert phi < 1e-12 and vel < 1e-9 and horizontal < 1e-6 and height < 1e-6
    # and the run is a real flight: 5.5 deg of longitude, navigated to within metres
    t = (new[0] + 1) * dt
    _, _, lla_true = truth.state(t)
    assert np.degrees(new[3][-1, 1] - new[3][0, 1]) > 3.0
    err = error_model.position_error_ned(new[3], lla_true)
    assert np.abs(err).max() < 50.0  # m; midpoint increments, free vertical channel


def _stationary_both(options):
    mat_nb, dtheta, dv, dt = _stationary_hour()
    quat = rotation.quat_from_mat(mat_nb)
    new, old = _both(
        quat, np.zeros(3), [LAT, LON, HEIGHT], dtheta, dv, dt, decimation=200, **options
    )
    assert len(new[0]) == 3600
    return new, old


@pytest.mark.slow
@pytest.mark.parametrize(
    "options",
    [{"fixed_position": True}, {"fixed_position": True, "zero_velocity": True}],
    ids=["fixed_position", "zero_velocity"],
)
def test_stationary_hour_fixed_position_is_bit_identical(options):
    _assert_identical(*_stationary_both(options))


@pytest.mark.slow
@pytest.mark.parametrize("options", [{"fixed_height": True}, {}], ids=["fixed_height", "free"])
def test_stationary_hour_free_modes_match_previous_kernel(options):
    phi, vel, horizontal, height = _differences(*_stationary_both(options))
    # measured: fixed height 3.5e-14 rad, 3.6e-12 m/s, 7.1e-10 m; free 1.6e-14 rad,
    # 9.2e-11 m/s, 7.1e-10 m, 5.2e-8 m (biases and noise: velocities up to 24 m/s after 1 h)
    assert phi < 1e-12 and vel < 1e-9 and horizontal < 1e-6 and height < 1e-6


def test_sincos_near_is_within_one_ulp_of_libm():
    rng = np.random.default_rng(0)
    grid = sd._GRID
    cells = np.round(rng.uniform(-1.57, 1.57, 3000) / grid) * grid
    offsets = rng.uniform(-0.5, 0.5, 3000) * grid
    worst = 0.0
    for ref, d in zip(cells, offsets, strict=True):
        s, c = sd._sincos_near(d, math.sin(ref), math.cos(ref))
        worst = max(worst, abs(s - math.sin(ref + d)), abs(c - math.cos(ref + d)))
    assert worst <= 2.0**-52  # measured 2.2e-16 (libm itself is within 1 ulp)


def test_free_earth_terms_are_within_a_few_ulp_of_the_direct_ones():
    # the free modes' Earth terms: root, root^3 and 1 / root by cell polynomials, one
    # division for both radii and 1 / cos; against the direct evaluation
    rng = np.random.default_rng(4)
    worst = np.zeros(7)
    for _ in range(400):
        ref = np.round(rng.uniform(-1.5, 1.5) / sd._GRID) * sd._GRID
        d = rng.uniform(-0.5, 0.5) * sd._GRID
        h = rng.uniform(-500.0, 12_000.0)
        s0, c0 = math.sin(ref), math.cos(ref)
        s, c = sd._sincos_near(d, s0, c0)
        new = sd._earth_terms_free(s, c, h, d, sd._cell_series(s0, c0))
        direct = (*sd._earth_terms(s, c, h), 1.0 / c)
        worst = np.maximum(worst, np.abs(np.subtract(new, direct)) / np.abs(direct))
    assert np.all(worst <= 2e-15), worst  # measured up to 6.8e-16 (1 / (R_N + h))


def test_earth_terms_match_earth_module():
    rng = np.random.default_rng(1)
    worst = np.zeros(6)
    for lat, h in zip(rng.uniform(-1.5, 1.5, 2000), rng.uniform(-500.0, 2e4, 2000), strict=True):
        terms = sd._earth_terms(math.sin(lat), math.cos(lat), h)
        rn, re = earth.principal_radii(lat)
        rate = earth.rate_ie_n(lat)
        ref = (
            rate[0],
            rate[2],
            1.0 / (rn + h),
            1.0 / (re + h),
            math.tan(lat),
            earth.gravity(lat, h),
        )
        worst = np.maximum(worst, np.abs(np.array(terms) / ref - 1.0))
    # Earth rate and gravity: the same arithmetic; inverse radii and tan within 2 ulp
    # (measured 4.4e-16, 3.3e-16, 3.3e-16)
    assert worst[0] == worst[1] == worst[5] == 0.0
    assert worst.max() <= 2.0**-51
