"""simulate-table against truth: exact increments, sensor errors, disturbances."""

import numpy as np
import pytest

from inins.commands.simulate_table import stream
from inins.core import earth, error_model, rotation, strapdown
from inins.core.units import ARCSEC, DEG_RTH, DPH, UG
from inins.results import MemorySink
from inins.scenario.si.table import table_simulation
from inins.scenario.simulate_table import SimulateTableScenario
from inins.table import simulate
from tests.helpers import shipped


def load(name, **updates):
    return table_simulation(shipped(SimulateTableScenario, f"simulate-table/{name}", **updates))


def run(sim, seed=0):
    return stream(sim, np.random.default_rng(seed), MemorySink())


def test_error_free_increments_reproduce_the_table_attitude():
    """Issue 2: integrating error-free increments over the whole 000 Table 1
    sequence (with the mount rotation) reproduces the true attitude < 0.1 arcsec."""
    sim = load("paper000-case2-roll-mount.yaml", **{"imu.gyro": {}, "imu.sample_rate_hz": 1000})
    sink = run(sim)
    mat0 = sim.trajectory.state([0.0])[0][0]
    state = strapdown.NavState.from_attitude(mat0, np.zeros(3), sim.trajectory.lla)
    _, nav = strapdown.integrate(
        state,
        sink["imu/dtheta"],
        sink["imu/dv"],
        sim.dt,
        fixed_position=True,
        decimation=sim.truth_decimation,
    )
    phi = error_model.attitude_error(
        rotation.mat_from_quat(nav.quat_nb), rotation.mat_from_quat(sink["truth/quat_nb"])
    )
    assert np.abs(phi).max() < 0.1 * ARCSEC
    np.testing.assert_allclose(nav.vel_n, 0.0, atol=1e-6)  # m/s, over 43 min
    # the truth really moved: two half turns and the mount rotation
    yaw = sink["truth/table_angles"][:, 0]
    assert yaw.max() == pytest.approx(np.pi, abs=1e-12)


def test_hold_mean_rate_is_earth_rate_plus_bias_within_noise():
    sim = load("default.yaml")
    sink = run(sim, seed=11)
    gyro = sim.sensor
    lat = sim.trajectory.lla[0]
    steps = sim.trajectory.program.steps
    dtheta = sink["imu/dtheta"].astype(float) * np.asarray(sink.attrs["imu/dtheta"]["pulse_weight"])
    for step in steps:
        if step.kind != "hold" or step.end - step.start < 600:
            continue
        k0 = int(np.ceil(step.start * sim.sample_rate)) + 1
        k1 = int(np.floor(step.end * sim.sample_rate)) - 1
        duration = (k1 - k0) * sim.dt
        rate = dtheta[k0:k1].sum(axis=0) / duration
        mid = 0.5 * (step.start + step.end)
        mat_nb = sim.trajectory.state([mid])[0][0]
        expected = mat_nb.T @ earth.rate_ie_n(lat) + gyro.gyro_bias
        # the mount turns the IMU at 0.005 deg / 1237 s about y during the holds
        expected[1] += 0.005 * np.pi / 180 / 1237.0 * (step.label != "align")
        sigma = np.sqrt(gyro.gyro_arw**2 / duration + (gyro.gyro_pulse_weight / duration) ** 2)
        assert np.all(np.abs(rate - expected) < 4 * sigma), (step.label, rate - expected, sigma)
        assert np.all(4 * sigma[:2] < np.abs(gyro.gyro_bias[:2]))  # a missing bias would fail


def test_accel_bias_after_rotation_and_chamber():
    sim = load(
        "default.yaml",
        **{
            "imu.accel.vrw_ug_rthz": 0.0,
            "imu.accel.pulse_weight_ug_s": 0.0,
            "imu.gyro.arw_deg_rth": 0.0,
        },
    )
    sink = run(sim)
    t = sink["truth/time"] - 0.5 / 10.0  # truth biases are means over 0.1 s windows
    bias = sink["truth/accel_bias"]
    base = sim.sensor.accel_bias
    first_turn_end = sim.trajectory.program.steps[2].end
    # before the first rotation: constant bias plus chamber drift 10 ug/degC * 0.1 degC * t/T
    k = np.searchsorted(t, first_turn_end) - 1
    drift = 10 * UG * 0.1 * t[k] / 1597.0
    np.testing.assert_allclose(bias[k], base + drift, atol=1e-3 * UG)
    # long after the second rotation: two 50 ug steps on x, two -50 on y
    last = sim.trajectory.program.steps[4].end
    k = np.searchsorted(t, last + 600) if t[-1] > last + 600 else -1
    settled = sum(1 - np.exp(-(t[k] - sim.trajectory.program.steps[i].end) / 120) for i in (2, 4))
    chamber = 10 * UG * 0.1 * min(t[k], 1597.0) / 1597.0
    expected = base + chamber + np.array([50, -50, 0]) * UG * settled
    np.testing.assert_allclose(bias[k], expected, atol=1e-3 * UG)


def test_a_chunked_run_equals_a_whole_one(monkeypatch):
    """The same seed gives the same file whether the run streams in 7 chunks or in one:
    the sensor error state, the bias instability and the encoder noise carry across."""
    sim = load(
        "paper000-case2-roll-mount.yaml",
        **{
            "imu.sample_rate_hz": 50,
            "imu.gyro.arw_deg_rth": 0.001,
            "imu.gyro.bias_instability_dph": 0.002,
            "table.encoder_noise_arcsec": 1.0,
        },
    )
    whole = run(sim, seed=5)
    assert sim.n_samples < simulate.CHUNK_SAMPLES  # one chunk
    monkeypatch.setattr(simulate, "CHUNK_SAMPLES", sim.n_samples // 7)
    chunked = run(sim, seed=5)
    for path in ("imu/dtheta", "imu/dv", "truth/gyro_bias", "truth/quat_nb", "table/encoder"):
        np.testing.assert_array_equal(chunked[path], whole[path], err_msg=path)


def test_seeds_reproduce():
    sim = load(
        "paper000-case1-no-disturbance.yaml",
        **{"imu.gyro": {"arw_deg_rth": 0.001, "bias_dph": 0.01}},
    )
    a, b = run(sim, seed=3), run(sim, seed=3)
    np.testing.assert_array_equal(a["imu/dtheta"], b["imu/dtheta"])
    c = run(sim, seed=4)
    assert not np.array_equal(a["imu/dtheta"], c["imu/dtheta"])
    n = sim.n_samples
    assert a["imu/dtheta"].shape == (n, 3) and a["truth/time"].shape == (n // 20,)
    assert sim.sensor.gyro_arw[0] == pytest.approx(0.001 * DEG_RTH)
    assert sim.sensor.gyro_bias[0] == pytest.approx(0.01 * DPH)
