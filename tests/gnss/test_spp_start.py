"""The start of the SPP iteration: Bancroft's closed-form solution (exact for ranges
without Earth rotation or atmosphere) and the same converged fixes as from the Earth's
centre, in fewer Gauss-Newton steps."""

import numpy as np

from inins.core import earth
from inins.gnss import spp


def _sky(rx, n_sat, rng):
    """Satellites 20,000-25,000 km away, spread over the sky of ``rx``."""
    up = rx / np.linalg.norm(rx)
    dirs = rng.normal(size=(n_sat, 3))
    dirs = dirs / np.linalg.norm(dirs, axis=1)[:, None]
    dirs = np.where((dirs @ up)[:, None] < 0.2, -dirs, dirs)  # above the horizon
    return rx + dirs * rng.uniform(2.0e7, 2.5e7, (n_sat, 1))


def test_bancroft_recovers_position_and_clock_exactly():
    rng = np.random.default_rng(4)
    rx = earth.ecef_from_llh(np.radians(48.1), np.radians(11.6), 520.0)
    sats = np.stack([_sky(rx, 7, rng), _sky(rx, 7, rng)])
    clock = np.array([1234.5, -77.0])  # m
    rho = np.linalg.norm(sats - rx, axis=-1) + clock[:, None]
    use = np.ones((2, 7), bool)
    use[1, 5:] = False  # five rows
    y = spp.bancroft(sats, rho, use)
    np.testing.assert_allclose(y[:, :3], [rx, rx], rtol=0, atol=1e-4)  # m
    np.testing.assert_allclose(y[:, 3], clock, rtol=0, atol=1e-4)  # m


def test_bancroft_gives_the_earths_centre_without_four_rows():
    rng = np.random.default_rng(5)
    rx = earth.ecef_from_llh(0.3, -1.2, 10.0)
    sats = _sky(rx, 6, rng)[None]
    use = np.array([[True, True, True, False, False, False]])
    y = spp.bancroft(sats, np.linalg.norm(sats - rx, axis=-1), use)
    assert np.array_equal(y, np.zeros((1, 4)))


def test_spp_from_bancroft_equals_spp_from_the_earths_centre(abpo_epochs):
    options = spp.SppOptions(mask_rad=np.radians(10.0))
    start = spp.solve(abpo_epochs, options)
    centre = spp.solve(abpo_epochs, options, initial=np.zeros(3))
    assert np.array_equal(start.status, centre.status)
    assert np.array_equal(start.n_used, centre.n_used)
    fix = start.status == spp.FixStatus.FIX
    assert fix.sum() > 2700
    # the same fixed point: the iteration stops at steps below 0.1 mm
    np.testing.assert_allclose(start.pos[fix], centre.pos[fix], rtol=0, atol=1e-6)  # m
    np.testing.assert_allclose(start.clock[fix], centre.clock[fix], rtol=0, atol=1e-6)  # m
