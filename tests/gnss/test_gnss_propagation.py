"""Propagation models against closed forms and finite differences."""

import numpy as np
import pytest

from inins.core import earth
from inins.core.units import DEG
from inins.gnss import constellation, ephemeris, orbit, propagation
from inins.gnss.orbit import OMEGA_E, C


def _light_time_range(eph, index, week, t_rx, rx_pos):
    """Exact range by iterating the light-time equation at receive time t_rx."""
    tau = 0.07
    for _ in range(6):
        s = orbit.satellite_states(eph, index, week, t_rx - tau)
        pos = propagation.sagnac_rotate(s.pos, tau)
        rho = np.linalg.norm(pos - rx_pos, axis=-1)
        tau = rho / C
    return rho, s


def test_range_rate_is_the_time_derivative_of_the_light_time_range():
    eph = constellation.walker(1826, 345600.0, 86400.0)
    rx0 = earth.ecef_from_llh(37 * DEG, 127 * DEG, 50.0)
    rx_vel = np.array([120.0, -80.0, 30.0])  # a fast vehicle
    t = 345600.0 + 4000.0
    idx = ephemeris.select(eph, np.arange(1, 25), 1826, np.full(24, t))

    def rho(dt):
        return _light_time_range(eph, idx, 1826, t + dt, rx0 + rx_vel * dt)[0]

    h = 1e-2
    fd = (rho(h) - rho(-h)) / (2 * h)
    r0, s = _light_time_range(eph, idx, 1826, t, rx0)
    rng, rate, _los, scale = propagation.geometry(s.pos, s.vel, rx0, rx_vel)
    np.testing.assert_allclose(rng, r0, atol=1e-6)
    assert np.abs(rate - fd).max() < 2e-5  # m/s; the (1 - tau_dot) factor matters at 1e-3
    assert np.abs(scale - 1.0).max() < 1e-5


def test_sagnac_correction_closed_form():
    """First order: rho_rot - rho = omega_e (x_s y_r - y_s x_r) / c, up to ~30 m."""
    rx = earth.ecef_from_llh(0.0, 0.0, 0.0)
    sat = np.array([[1.5e7, 2.0e7, 5.0e6], [1.5e7, -2.0e7, 5.0e6]])
    rng, _, _, _ = propagation.geometry(sat, np.zeros_like(sat), rx)
    plain = np.linalg.norm(sat - rx, axis=1)
    first = OMEGA_E * (sat[:, 0] * rx[1] - sat[:, 1] * rx[0]) / C
    np.testing.assert_allclose(rng - plain, first, atol=1e-3)
    assert np.abs(first).max() > 30.0


def test_elevation_and_azimuth_of_known_directions():
    lat, lon = 37 * DEG, 127 * DEG
    rx = earth.ecef_from_llh(lat, lon, 0.0)
    c_en = earth.mat_en(lat, lon)
    dirs_n = np.array([[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, 1.0, -1.0] / np.sqrt(2)])
    el, az = propagation.elevation_azimuth(dirs_n @ c_en.T, np.broadcast_to(rx, (3, 3)))
    np.testing.assert_allclose(el, [np.pi / 2, 0.0, np.pi / 4], atol=1e-12)
    np.testing.assert_allclose(az[1:], [0.0, np.pi / 2], atol=1e-12)


def test_saastamoinen_standard_atmosphere():
    zenith = propagation.troposphere_saastamoinen(0.0, 0.0, np.pi / 2)
    # 0.002277 (1013.25 + (1255/288.15 + 0.05) e), e = 6.108 * 0.5 * exp(...) = 8.5 hPa
    e = 6.108 * 0.5 * np.exp((17.15 * 288.15 - 4684.0) / (288.15 - 38.45))
    assert zenith == pytest.approx(0.002277 * (1013.25 + (1255 / 288.15 + 0.05) * e), rel=1e-12)
    assert 2.3 < zenith < 2.45  # m: the textbook 2.3 m dry + ~0.1 m wet at sea level
    low = propagation.troposphere_saastamoinen(0.0, 0.0, 10 * DEG)
    # 1/cos z mapping with Saastamoinen's -tan^2 z bending term: 3 % below 1/sin(el) at 10 deg
    assert low == pytest.approx(
        zenith / np.sin(10 * DEG) - 0.002277 * np.tan(80 * DEG) ** 2 / np.sin(10 * DEG), rel=1e-9
    )
    assert low / zenith == pytest.approx(0.969 / np.sin(10 * DEG), rel=0.002)
    high = propagation.troposphere_saastamoinen(3000.0, 0.0, np.pi / 2)
    assert high / zenith == pytest.approx(0.70, abs=0.03)  # pressure ratio at 3 km
    assert propagation.troposphere_saastamoinen(0.0, 0.0, -0.1) == 0.0


def test_klobuchar_night_value_and_daytime_peak():
    alpha = np.array([1.1176e-8, 7.4506e-9, -5.9605e-8, -5.9605e-8])
    beta = np.array([9.0112e4, 4.9152e4, -1.3107e5, -3.2768e5])
    zenith_night = propagation.ionosphere_klobuchar(0.0, 0.0, 0.0, np.pi / 2, 0.0, alpha, beta)
    f = 1.0 + 16.0 * (0.53 - 0.5) ** 3
    assert zenith_night == pytest.approx(C * 5e-9 * f, rel=1e-12)  # 1.5 m at night
    lon = 0.0
    noon = 50400.0 - 4.32e4 * lon / np.pi
    day = propagation.ionosphere_klobuchar(noon, 0.0, lon, np.pi / 2, 0.0, alpha, beta)
    assert day > 3 * zenith_night


def test_ionosphere_free_removes_first_order_delay():
    rho, iono = 2.2e7, 7.3
    p1 = rho + iono
    p2 = rho + propagation.GAMMA_12 * iono
    assert propagation.ionosphere_free(p1, p2) == pytest.approx(rho, abs=1e-7)
    assert propagation.LAMBDA_L1 == pytest.approx(0.1902936728, abs=1e-10)
