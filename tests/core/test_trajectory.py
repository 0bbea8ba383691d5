"""Truth trajectories: closed forms, complex-step derivatives, exact increments across steps."""

import itertools

import numpy as np
import pytest

from inins.core import earth, flight, rotation
from inins.core import trajectory as tr
from inins.core.units import DEG

LAT, LON, HEIGHT = 37.0 * DEG, 127.0 * DEG, 250.0


def _rel_err(value, expected):
    return np.abs(value - expected).max() / np.abs(expected).max()


def test_stationary_increments_are_earth_rate_and_gravity():
    mat_nb = rotation.mat_from_euler(0.02, -0.01, 2.0)
    truth = tr.Stationary(LAT, LON, HEIGHT, mat_nb)
    edges = 3000.0 + np.arange(2001) * 0.005
    dtheta, dv = tr.ideal_increments(truth, edges)
    dt = np.diff(edges)[:, None]
    omega_b = mat_nb.T @ earth.rate_ie_n(LAT)
    force_b = -mat_nb.T @ earth.gravity_n(LAT, HEIGHT)
    assert _rel_err(dtheta, omega_b * dt) < 1e-15
    assert _rel_err(dv, force_b * dt) < 1e-15


def test_complex_step_and_45_degree_second_derivative():
    t = np.linspace(-3.0, 7.0, 101)

    def func(z):
        return np.sin(3.0 * z) * np.exp(0.1 * z) + z**3

    s, c, e = np.sin(3.0 * t), np.cos(3.0 * t), np.exp(0.1 * t)
    first = (3.0 * c + 0.1 * s) * e + 3.0 * t**2
    second = (-9.0 * s + 0.6 * c + 0.01 * s) * e + 6.0 * t
    value, slope = tr.complex_step(func, t)
    assert _rel_err(value, func(t)) < 1e-15
    assert _rel_err(slope, first) < 1e-15
    assert _rel_err(tr.second_derivative(func, t, 0.01), second) < 1e-9


def test_smooth_velocity_derivatives_by_full_complex_step():
    # a finite imaginary part (1e-10 s) takes the general complex path, so this
    # checks the closed-form derivatives of the logistic steps independently
    vel = flight.flight_velocity()
    t = np.linspace(0.0, 600.0, 601)
    for order in (-1, 0, 1):
        slope = vel(t + 1e-10j, order).imag / 1e-10
        assert _rel_err(slope, vel(t, order + 1)) < 1e-12
        dual = vel(t + 1j * tr.CS_STEP, order).imag / tr.CS_STEP
        assert _rel_err(dual, vel(t, order + 1)) < 1e-15


def _central(func, t, h):
    """Fourth-order central difference of ``func`` (returns an array) at ``t``."""
    return (-func(t + 2 * h) + 8 * func(t + h) - 8 * func(t - h) + func(t - 2 * h)) / (12 * h)


def test_aircraft_rates_match_derivatives_of_its_state():
    truth = flight.aircraft_trajectory()
    t = np.array([5.0, 95.0, 101.0, 215.0, 333.0, 455.0, 545.0])
    mat_nb, vel_n, lla = truth.state(t)
    mat_dot = _central(lambda x: truth.state(x)[0], t, 1e-3)
    skew = np.swapaxes(mat_nb, 1, 2) @ mat_dot
    omega_nb_b = np.stack([skew[:, 2, 1], skew[:, 0, 2], skew[:, 1, 0]], -1)
    acc_n = _central(lambda x: truth.state(x)[1], t, 1e-3)
    omega_ref, force_ref = tr.body_rates(mat_nb, omega_nb_b, vel_n, acc_n, lla)
    omega, force = truth.rates(t)
    assert np.abs(omega - omega_ref).max() < 1e-10  # rad/s
    assert np.abs(force - force_ref).max() < 1e-7  # m/s^2
    # vel_n is the derivative of the ECEF position, resolved in NED
    r_dot = _central(lambda x: earth.ecef_from_llh(*truth.state(x)[2].T), t, 1e-3)
    vel_ref = np.einsum("kji,kj->ki", earth.mat_en(lla[:, 0], lla[:, 1]), r_dot)
    assert np.abs(vel_n - vel_ref).max() < 1e-5  # m/s, round-off of the difference


def test_aircraft_profile_and_second_derivative_fallback():
    truth = flight.aircraft_trajectory()
    t = np.linspace(0.0, 600.0, 6001)
    mat_nb, vel_n, _ = truth.state(t)
    euler = rotation.euler_from_mat(mat_nb)
    speed = np.linalg.norm(vel_n[:, :2], axis=1)
    assert 29.0 < np.degrees(euler[:, 0]).max() < 31.5
    assert -31.5 < np.degrees(euler[:, 0]).min() < -29.0
    assert 49.0 < speed.min() < 51.0 and 149.0 < speed.max() < 151.0
    assert vel_n[:, 2].min() < -4.5 and vel_n[:, 2].max() > 7.5  # climbs and a descent
    plain = tr.Analytic(truth.roll, truth.pitch, truth.heading, truth.lat, truth.lon, truth.height)
    omega, force = truth.rates(t)
    omega2, force2 = plain.rates(t)
    assert np.abs(omega2 - omega).max() < 1e-15
    assert np.abs(force2 - force).max() < 1e-7  # 45-degree step, O(h^4)


def _level_turns(marks, rate):
    """Level body at rest turning at ``rate`` between ``marks[0]`` and ``marks[1]``."""
    t0, t1 = marks

    def heading(t):
        r = np.real(t)
        return np.where(r < t0, 0.0 * t, np.where(r < t1, rate * (t - t0), rate * (t1 - t0)))

    def const(value):
        return lambda t: value + 0.0 * t

    return tr.Analytic(
        const(0.0),
        const(0.0),
        heading,
        const(LAT),
        const(LON),
        const(HEIGHT),
        const(0.0),
        const(0.0),
        const(0.0),
        breakpoints=marks,
    )


def _exact_level_turn_increment(a, b, marks, rate):
    """Closed-form int omega_ib_b dt over [a, b] for :func:`_level_turns`."""
    w_n, w_d = earth.RATE * np.cos(LAT), -earth.RATE * np.sin(LAT)
    total = np.zeros(3)
    pieces = np.sort(np.concatenate([[a, b], [m for m in marks if a < m < b]]))
    for lo, hi in itertools.pairwise(pieces):
        turning = marks[0] <= lo < marks[1]
        r = rate if turning else 0.0
        psi_lo = rate * (np.clip(lo, *marks) - marks[0])
        psi_hi = psi_lo + r * (hi - lo)
        if turning:
            cos_int = (np.sin(psi_hi) - np.sin(psi_lo)) / r
            sin_int = (np.cos(psi_lo) - np.cos(psi_hi)) / r
        else:
            cos_int, sin_int = np.cos(psi_lo) * (hi - lo), np.sin(psi_lo) * (hi - lo)
        # omega_ib_b = Rz(psi)^T omega_ie_n + [0, 0, psi']
        total += [w_n * cos_int, -w_n * sin_int, (w_d + r) * (hi - lo)]
    return total


def test_rate_steps_inside_samples_are_integrated_exactly():
    rate, dt = 0.3, 0.01
    edges = np.arange(101) * dt
    # both steps inside one sample, then one step per sample, then steps on edges
    for marks in ((0.2013, 0.2087), (0.3141, 0.5926), (0.3, 0.6)):
        truth = _level_turns(marks, rate)
        dtheta, dv = tr.ideal_increments(truth, edges)
        exact = np.array(
            [_exact_level_turn_increment(a, b, marks, rate) for a, b in itertools.pairwise(edges)]
        )
        assert np.abs(dtheta - exact).max() < 1e-17  # rad, vs increments ~3e-3 rad
        force = -earth.gravity(LAT, HEIGHT) * dt
        assert np.abs(dv - [0.0, 0.0, force]).max() < 2e-15  # m/s, vs 0.098 m/s
    # the same steps without declared breakpoints are integrated visibly wrong
    blind = _level_turns((0.3141, 0.5926), rate)
    object.__setattr__(blind, "breakpoints", np.empty(0))
    dtheta, _ = tr.ideal_increments(blind, edges)
    exact = np.array(
        [
            _exact_level_turn_increment(a, b, (0.3141, 0.5926), rate)
            for a, b in itertools.pairwise(edges)
        ]
    )
    assert np.abs(dtheta - exact).max() > 1e-5


def test_coning_rates_match_its_attitude():
    truth = tr.Coning(2.0 * DEG, 5.0, LAT, LON, HEIGHT, rotation.mat_from_euler(0.1, 0.2, 0.3))
    t = np.linspace(0.0, 0.4, 41)
    mat_nb = truth.state(t)[0]
    mat_dot = _central(lambda x: truth.state(x)[0], t, 1e-4)
    skew = np.swapaxes(mat_nb, 1, 2) @ mat_dot
    omega_nb_b = np.stack([skew[:, 2, 1], skew[:, 0, 2], skew[:, 1, 0]], -1)
    omega, force = truth.rates(t)
    earth_b = np.einsum("kji,j->ki", mat_nb, earth.rate_ie_n(LAT))
    assert np.abs(omega - earth_b - omega_nb_b).max() < 1e-10
    theta, w = 2.0 * DEG, 2.0 * np.pi * 5.0
    axial = omega[:, 0] - earth_b[:, 0]
    assert np.abs(axial + 2.0 * w * np.sin(theta / 2) ** 2).max() < 1e-15
    transverse = np.hypot(*(omega - earth_b)[:, 1:].T)
    assert np.abs(transverse - w * np.sin(theta)).max() < 1e-14
    assert np.abs(np.linalg.norm(force, axis=1) - earth.gravity(LAT, HEIGHT)).max() < 1e-14


def test_bad_time_edges_raise():
    truth = tr.Stationary(LAT, LON, HEIGHT)
    with pytest.raises(ValueError, match="strictly increasing"):
        tr.ideal_increments(truth, [0.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="lat_rate"):
        tr.Analytic(*[np.sin] * 6, lat_rate=np.sin)
