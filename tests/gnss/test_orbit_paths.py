"""The two code paths of :func:`inins.gnss.orbit.satellite_states`: numpy array
arithmetic for small requests (no numba loaded), the compiled loop for large ones. They
compute the same expressions in the same order, so they agree to the rounding of the
trigonometric functions: well below a micrometre and a femtosecond."""

from pathlib import Path

import numpy as np

from inins.gnss import broadcast, orbit, systems
from inins.io.rinex_nav import read_navigation

DATA = Path(__file__).resolve().parents[2] / "data" / "smartloc"


def test_numpy_and_compiled_states_agree_for_every_kepler_system():
    mixed = read_navigation(DATA / "BRDC00WRD_U_20161580000_01D_MN.rnx.gz", leap_seconds=17)
    eph = broadcast.from_records(mixed.records, mixed.glonass).kepler
    geo = [k for k, p in enumerate(eph.prn.tolist()) if orbit._is_geo(p)]
    assert geo and set(systems.system_of(eph.prn).tolist()) == {0, 2, 3}
    rng = np.random.default_rng(3)
    index = np.repeat(np.arange(len(eph.prn)), 40)
    sow = eph.toe[index] + rng.uniform(-7200.0, 7200.0, index.size)
    args = (index, eph.week.astype(np.int64)[index], sow)
    states = {}
    for label, limit in (("numpy", 10**9), ("compiled", -1)):
        saved, orbit.NUMPY_STATES = orbit.NUMPY_STATES, limit
        try:
            states[label] = orbit.satellite_states(eph, *args, tgd=True)
        finally:
            orbit.NUMPY_STATES = saved
    a, b = states["numpy"], states["compiled"]
    np.testing.assert_allclose(a.pos, b.pos, rtol=0, atol=1e-6)  # m
    np.testing.assert_allclose(a.vel, b.vel, rtol=0, atol=1e-9)  # m/s
    np.testing.assert_allclose(a.clock, b.clock, rtol=0, atol=1e-6)  # m (3 fs)
    np.testing.assert_allclose(a.drift, b.drift, rtol=0, atol=1e-9)  # m/s
    moved = np.linalg.norm(a.pos - b.pos, axis=1)
    assert np.isfinite(moved).all() and np.linalg.norm(a.pos, axis=1).min() > 2e7
