"""The two code paths of :func:`inins.gnss.orbit.satellite_states`: numpy array
arithmetic for small requests (no numba loaded), the compiled loop for large ones. They
compute the same expressions in the same order, so they agree to the rounding of the
trigonometric functions: well below a micrometre and a femtosecond."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from inins.core import jit
from inins.gnss import broadcast, glonass, orbit, systems
from inins.io.rinex_nav import read_navigation

DATA = Path(__file__).resolve().parents[2] / "data" / "smartloc"


def test_numpy_and_compiled_states_agree_for_every_kepler_system(monkeypatch):
    mixed = read_navigation(DATA / "BRDC00WRD_U_20161580000_01D_MN.rnx.gz", leap_seconds=17)
    eph = broadcast.from_records(mixed.records, mixed.glonass).kepler
    geo = [k for k, p in enumerate(eph.prn.tolist()) if orbit._is_geo(p)]
    assert geo and set(systems.system_of(eph.prn).tolist()) == {0, 2, 3}
    rng = np.random.default_rng(3)
    index = np.repeat(np.arange(len(eph.prn)), 40)
    sow = eph.toe[index] + rng.uniform(-7200.0, 7200.0, index.size)
    args = (index, eph.week.astype(np.int64)[index], sow)
    states = []
    for numpy_path in (True, False):
        monkeypatch.setattr(orbit, "_use_numpy", lambda count, path=numpy_path: path)
        states.append(orbit.satellite_states(eph, *args, tgd=True))
    a, b = states
    np.testing.assert_allclose(a.pos, b.pos, rtol=0, atol=1e-6)  # m
    np.testing.assert_allclose(a.vel, b.vel, rtol=0, atol=1e-9)  # m/s
    np.testing.assert_allclose(a.clock, b.clock, rtol=0, atol=1e-6)  # m (3 fs)
    np.testing.assert_allclose(a.drift, b.drift, rtol=0, atol=1e-9)  # m/s
    assert np.linalg.norm(a.pos, axis=1).min() > 2e7


def test_the_numpy_path_serves_small_requests_while_numba_is_not_loaded(monkeypatch):
    lazy = jit.Kernel(orbit._states_kernel.py_func, {})
    monkeypatch.setattr(orbit, "_states_kernel", lazy)
    assert orbit._use_numpy(orbit.NUMPY_STATES) and not orbit._use_numpy(orbit.NUMPY_STATES + 1)
    monkeypatch.setattr(orbit, "_states_kernel", jit.activate().njit(lazy.py_func))
    assert not orbit._use_numpy(10)


SMARTLOC = str(DATA.parents[1] / "configs" / "import-flight" / "smartloc-gps-glonass.yaml")


@pytest.mark.parametrize("scenario", [[], [SMARTLOC]], ids=["abpo-gps", "smartloc-gps-glonass"])
def test_import_flight_on_rinex_loads_no_kernel(tmp_path, scenario):
    """import-flight on RINEX (the default, GPS; smartLoc, GPS + GLONASS) runs without
    numba, scipy or rich (stdout not a terminal)."""
    code = (
        f"import sys\nfrom inins.cli import main\nsys.argv = ['inins', 'import-flight', "
        f"*{scenario!r}, '-o', {str(tmp_path)!r}]\ntry:\n    main()\nexcept SystemExit:\n"
        "    pass\n"
        "print(sorted(m for m in ('numba', 'scipy', 'rich') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "[]"
    assert (tmp_path / "summary.json").is_file(), out.stderr  # the run went through


def test_numpy_and_compiled_glonass_integration_agree(monkeypatch):
    """GLONASS RK4 from each set's tb, up to 15 min either way (several steps)."""
    mixed = read_navigation(DATA / "BRDC00WRD_U_20161580000_01D_MN.rnx.gz", leap_seconds=17)
    eph = broadcast.from_records(mixed.records, mixed.glonass).glonass
    rng = np.random.default_rng(2)
    index = np.repeat(np.arange(len(eph.sat)), 5)
    sow = eph.toe[index] + rng.uniform(-900.0, 900.0, index.size)
    sow[:3] = eph.toe[index[:3]]  # no step at all
    states = []
    for numpy_path in (True, False):
        monkeypatch.setattr(glonass, "_use_numpy", lambda count, path=numpy_path: path)
        states.append(glonass.satellite_states(eph, index, eph.week[index], sow))
    a, b = states
    np.testing.assert_allclose(a.pos, b.pos, rtol=0, atol=1e-6)  # m
    np.testing.assert_allclose(a.vel, b.vel, rtol=0, atol=1e-9)  # m/s
    assert np.array_equal(a.clock, b.clock)
    assert np.linalg.norm(a.pos, axis=1).min() > 2.5e7  # GLONASS orbits, 25,500 km
