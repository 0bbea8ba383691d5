"""WGS84 radii and normal gravity against published values; geodetic <-> ECEF."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from inins.core import earth


def test_normal_gravity_published_values():
    # NIMA TR8350.2 Table 3.4: equator and poles
    assert abs(earth.gravity(0.0, 0.0) - 9.7803253359) < 1e-10
    assert abs(earth.gravity(np.pi / 2, 0.0) - 9.8321849378) < 1e-10
    assert abs(earth.gravity(-np.pi / 2, 0.0) - 9.8321849378) < 1e-10


def test_gravity_height_gradient():
    # free-air gradient about -3.086e-6 s^-2 at mid latitudes
    lat = np.radians(45.0)
    grad = (earth.gravity(lat, 1000.0) - earth.gravity(lat, 0.0)) / 1000.0
    assert abs(grad + 3.086e-6) < 0.01e-6


def test_radii_closed_forms():
    rn, re = earth.principal_radii(0.0)
    assert abs(re - earth.A) < 1e-9
    assert abs(rn - earth.A * (1 - earth.E2)) < 1e-9
    rn, re = earth.principal_radii(np.pi / 2)
    polar = earth.A**2 / earth.B  # both radii equal a^2/b at the pole
    assert abs(rn - polar) < 1e-6 and abs(re - polar) < 1e-6


def test_rates():
    lat = np.radians(37.0)
    w = earth.rate_ie_n(lat)
    np.testing.assert_allclose(np.linalg.norm(w), 7.292115e-5, rtol=1e-15)
    assert w[0] > 0 and w[2] < 0
    rn, re = earth.principal_radii(lat)
    rho = earth.rate_en_n(lat, 100.0, [10.0, 20.0, 0.0])
    np.testing.assert_allclose(
        rho, [20 / (re + 100), -10 / (rn + 100), -20 * np.tan(lat) / (re + 100)], rtol=1e-15
    )


def test_ecef_known_points():
    np.testing.assert_allclose(earth.ecef_from_llh(0.0, 0.0, 0.0), [earth.A, 0, 0], atol=1e-9)
    np.testing.assert_allclose(earth.ecef_from_llh(np.pi / 2, 0.0, 0.0), [0, 0, earth.B], atol=1e-9)


@settings(max_examples=200, deadline=None)
@given(st.floats(-np.pi / 2, np.pi / 2), st.floats(-np.pi, np.pi), st.floats(-1e4, 3e7))
def test_llh_ecef_round_trip(lat, lon, h):
    r = earth.ecef_from_llh(lat, lon, h)
    lat2, lon2, h2 = earth.llh_from_ecef(r)
    assert abs(lat2 - lat) < 1e-11  # < 0.1 mm on the ground
    if abs(lat) < np.pi / 2 - 1e-9:
        assert abs(np.angle(np.exp(1j * (lon2 - lon)))) < 1e-11
    assert abs(h2 - h) < 1e-5


def test_mat_en_columns():
    lat, lon = np.radians(37.0), np.radians(127.0)
    m = earth.mat_en(lat, lon)
    np.testing.assert_allclose(m.T @ m, np.eye(3), atol=1e-15)
    # down points along minus the ellipsoid normal: check with a small height step
    d = earth.ecef_from_llh(lat, lon, 0.0) - earth.ecef_from_llh(lat, lon, 1.0)
    np.testing.assert_allclose(m[:, 2], d, atol=1e-9)
