"""Table-free multi-position calibration (Tedaldi et al. 2014): simulated truth through
simulate-table, and the Xsens log of the imu_tk test data (real)."""

import os

import numpy as np
import pytest
from helpers import CONFIGS, SHARED_DATA, shipped

from inins.calibration import imu_model, tablefree
from inins.commands._table import memory_record
from inins.core import earth
from inins.core.units import DPH
from inins.io.rawlog import read_raw_log
from inins.scenario.calibrate_imu import CalibrateImuScenario
from inins.scenario.si.table import table_simulation
from inins.table import simulate

DETECTOR = tablefree.Detector(window=1.0, init=15.0, threshold_factor=6.0, min_interval=2.0)


def _mems_record(**sets):
    s = shipped(
        CalibrateImuScenario,
        "calibrate-imu/table-free-mems.yaml",
        "simulate.imu.gyro.arw_deg_rth=0",
        "simulate.imu.accel.vrw_ug_rthz=0",
        **sets,
    ).simulate
    sim = table_simulation(s)
    rec = memory_record(sim, simulate.simulation_chunks(sim, np.random.default_rng(0)))
    return sim, rec


def _inputs(sim, rec, remove_earth_rate):
    n = rec.n_samples
    time = rec.dt * (np.arange(n) + 1)
    rate = rec.dtheta / rec.dt
    if remove_earth_rate:  # the Earth rate each sample saw (true attitude), as measured
        mat_nb, _, _ = sim.trajectory.state(time - 0.5 * rec.dt)
        w_ie = np.einsum("kji,j->ki", mat_nb, earth.rate_ie_n(rec.lla[0]))
        rate = rate - w_ie @ sim.sensor.gyro_matrix().T
    return time, rec.dv / rec.dt, rate, float(earth.gravity(rec.lla[0], rec.lla[2]))


def test_noise_free_exact_once_the_earth_rate_is_out():
    # the method's model has no Earth rate: with it removed from the data, every one of
    # the 21 terms comes back (the gyro terms through the integrated rotations)
    sim, rec = _mems_record()
    fit = tablefree.calibrate(*_inputs(sim, rec, True), DETECTOR)
    assert len(fit.used) == 12
    truth = imu_model.terms_from_sensor(sim.sensor).vector(fit.names)
    err = np.abs(fit.values - truth)
    # 1e-4 relative, or 1e-9 absolute (SI) for the terms near zero
    assert np.all((err <= 1e-4 * np.abs(truth)) | (err <= 1e-9)), list(
        zip(fit.names, err / np.abs(truth), strict=True)
    )


def test_noise_free_with_earth_rate_is_at_its_model_limit():
    # as the method runs on real data: accelerometer terms exact, gyro bias off by the
    # Earth rate seen at the first position (at most |W| = 15.04 deg/h)
    sim, rec = _mems_record()
    fit = tablefree.calibrate(*_inputs(sim, rec, False), DETECTOR)
    truth = imu_model.terms_from_sensor(sim.sensor)
    for n in tablefree.ACCEL_NAMES:
        k = fit.names.index(n)
        assert abs(fit.values[k] - truth[n]) <= 1e-6 * abs(truth[n])
    bias = fit.terms.gyro_bias() - truth.gyro_bias()
    mat_nb, _, _ = sim.trajectory.state(np.array([1.0]))
    seen = sim.sensor.gyro_matrix() @ mat_nb[0].T @ earth.rate_ie_n(rec.lla[0])
    np.testing.assert_allclose(bias, seen, atol=1e-3 * DPH)
    assert np.linalg.norm(bias) <= np.linalg.norm(sim.sensor.gyro_matrix(), 2) * earth.RATE


def test_noise_free_with_the_earth_rate_modelled_recovers_all_21_terms():
    # the same record as it comes (the Earth rate in it), the latitude given: the bias is
    # the sensor's alone and the gyro matrix exact, the heading of the first position
    # found (the table's 0 deg); 1e-4 relative or 1e-9 SI (the simulator's midpoint
    # quadrature of the 60 deg/s turns: (w dt)^2 / 24 = 5e-6 at 100 Hz)
    sim, rec = _mems_record()
    fit = tablefree.calibrate(*_inputs(sim, rec, False), DETECTOR, lat=rec.lla[0])
    assert fit.earth_rate and not fit.verdict.inseparable
    truth = imu_model.terms_from_sensor(sim.sensor).vector(fit.names)
    err = np.abs(fit.values - truth)
    assert np.all((err <= 1e-4 * np.abs(truth)) | (err <= 1e-9)), list(
        zip(fit.names, err / np.abs(truth), strict=True)
    )
    assert abs(np.degrees(fit.heading)) < 0.01
    # imu_tk's formulation on the same record: the bias off by the Earth rate
    tk = tablefree.calibrate(*_inputs(sim, rec, False), DETECTOR)
    assert np.linalg.norm(tk.terms.gyro_bias() - fit.terms.gyro_bias()) > 10 * DPH


def test_detector_flags_a_moving_static_interval():
    # a slow 3 deg turn over 6 s (0.5 deg/s) keeps the variance below the threshold
    # (noise 0.01 m/s^2) but turns the gravity direction: flagged as moving, not used
    t = np.arange(0, 60, 0.01)
    acc = np.tile([0.0, 0.0, -9.8], (t.size, 1))
    ang = np.clip((t - 30) / 6.0, 0, 1) * np.radians(3.0)
    acc[:, 0] = -9.8 * np.sin(ang)
    acc[:, 2] = -9.8 * np.cos(ang)
    acc += np.random.default_rng(0).normal(0.0, 0.01, acc.shape)  # 0.01 m/s^2 white
    found, _ = tablefree.detect_static(t, acc, tablefree.Detector(init=10.0))
    assert [iv.flag[:6] for iv in found] == ["moving"]
    # without the turn the same record is one clean static interval
    still = np.tile([0.0, 0.0, -9.8], (t.size, 1))
    still += np.random.default_rng(0).normal(0.0, 0.01, acc.shape)
    found, _ = tablefree.detect_static(t, still, tablefree.Detector(init=10.0))
    assert [iv.flag for iv in found] == [""]


REAL = SHARED_DATA / "imu-multipos"


@pytest.fixture(scope="module")
def xsens():
    """The Xsens log as the shipped scenario reads it (packaged copy)."""
    from inins.commands.calibrate_imu import _raw_log

    s = shipped(CalibrateImuScenario, "calibrate-imu/xsens-real.yaml")
    return s, _raw_log(s)


def test_packaged_log_is_the_original():
    if not REAL.is_dir():
        pytest.skip(f"the original imu_tk test data ({REAL}) is not on this machine")
    acc, gyro = np.loadtxt(REAL / "xsens_acc.mat"), np.loadtxt(REAL / "xsens_gyro.mat")
    t1, a1, g1 = read_raw_log(
        CONFIGS.parent / "data/xsens-multipos-acc.txt.gz",
        CONFIGS.parent / "data/xsens-multipos-gyro.txt.gz",
        (0.0, 65535.0),
    )
    np.testing.assert_array_equal(t1, acc[:, 0])
    np.testing.assert_array_equal(a1, acc[:, 1:])
    np.testing.assert_array_equal(g1, gyro[:, 1:])


def test_xsens_gravity_norm_residual_and_stability(xsens):
    s, (time, acc, gyro, gravity) = xsens
    d = s.table_free.detector
    det = tablefree.Detector(d.window_s, d.init_interval_s, d.threshold_factor, d.min_interval_s)
    fit = tablefree.calibrate(time, acc, gyro, gravity, det)
    before = np.sqrt(np.mean(fit.norm_before**2))
    after = np.sqrt(np.mean(fit.norm_after**2))
    # raw counts minus 32768 with the one-point nominal scale: 1.26 m/s^2 RMS over the
    # 38 static intervals; calibrated: 0.98 mm/s^2 (about 100 ug)
    assert len(fit.used) == 38
    assert 1.2 < before < 1.35
    assert after < 1.2e-3
    # the gravity direction after each rotation, nominal gyros (1/6258 rad/s per count)
    # against calibrated: 0.39 -> 0.005 (RMS of the unit-vector residual)
    assert np.sqrt(np.mean(fit.gravity_residual_after**2)) < 0.1 * np.sqrt(
        np.mean(fit.gravity_residual_before**2)
    )
    # half of the positions (every other one): the same calibration within the 1-sigma
    # of the half (3 sigma), for the accelerometer terms and the gyro matrix
    half = tablefree.calibrate(time, acc, gyro, gravity, det, use=range(0, len(fit.used), 2))
    assert len(half.used) == 19
    diff = np.abs(half.values - fit.values)
    for n in tablefree.ACCEL_NAMES + tablefree.GYRO_NAMES:
        k = fit.names.index(n)
        assert diff[k] <= 3.0 * half.sigma[k], (n, diff[k], half.sigma[k])


@pytest.mark.skipif(
    not os.environ.get("ININS_LONG"),
    reason="50-seed Monte Carlo of the table-free method (about 20 s): ININS_LONG=1",
)
def test_monte_carlo_sigma_and_planner():
    # noise only: the Earth rate (the model's limit, tested above) removed from the data
    from dataclasses import replace

    from inins.core import imu

    s = shipped(CalibrateImuScenario, "calibrate-imu/table-free-mems.yaml").simulate
    sim = table_simulation(s)
    truth = imu_model.terms_from_sensor(sim.sensor)
    ideal = replace(sim, sensor=imu.SensorErrors.none())
    rec = memory_record(ideal, simulate.simulation_chunks(ideal, np.random.default_rng(0)))
    t, acc, gyro, g = _inputs(ideal, rec, False)
    planned = tablefree.plan(t, acc, gyro, g, sim.sensor.accel_vrw, sim.sensor.gyro_arw, DETECTOR)
    z, errs = [], []
    for seed in range(50):
        rec = memory_record(sim, simulate.simulation_chunks(sim, np.random.default_rng(seed)))
        fit = tablefree.calibrate(*_inputs(sim, rec, True), DETECTOR)
        err = fit.values - truth.vector(fit.names)
        z.append(err / fit.sigma)
        errs.append([err[fit.names.index(n)] for n in planned.names])
    z, errs = np.array(z), np.array(errs)
    assert np.mean(np.abs(z) < 3.0) >= 0.99
    assert 0.8 <= np.sqrt(np.mean(z**2)) <= 1.25
    ratio = np.sqrt(np.mean(errs**2, axis=0)) / planned.sigma
    print("MC table-free:", np.mean(np.abs(z) < 3.0), np.sqrt(np.mean(z**2)), ratio.round(2))
    for part in (slice(0, 9), slice(9, 18)):  # accelerometer, gyro matrix: pooled
        assert abs(np.sqrt(np.mean(ratio[part] ** 2)) - 1.0) < 0.2


def test_the_first_heading_is_found_at_any_azimuth(monkeypatch):
    """The Earth rate modelled, the table's x axis 130 deg from north: the heading of the
    first position comes back within 0.01 deg noise-free, and the joint fit starts near
    it (the gyrocompass of every position, linear in the bias and the cos and sin of
    the heading: within 5 deg, 2 deg measured; a sign error there starts the fit at the
    mirror heading, -128 deg, from which it still converges, so only this catches it)."""
    import scipy.optimize

    starts = []
    solve = scipy.optimize.least_squares

    def spy(fun, x0, *args, **kwargs):
        starts.append(np.array(x0, float))
        return solve(fun, x0, *args, **kwargs)

    monkeypatch.setattr(scipy.optimize, "least_squares", spy)
    sim, rec = _mems_record(**{"simulate.table.base_azimuth_deg": 130.0})
    fit = tablefree.calibrate(*_inputs(sim, rec, False), DETECTOR, lat=rec.lla[0])
    assert abs((np.degrees(fit.heading) - 130.0 + 180.0) % 360.0 - 180.0) < 0.01
    start = next(x for x in starts if x.size == 13)[12]  # 9 matrix terms, bias, heading
    assert abs((np.degrees(start) - 130.0 + 180.0) % 360.0 - 180.0) < 5.0
