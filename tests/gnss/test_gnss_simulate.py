"""Simulated receiver: SPP recovers the truth; noise statistics; fault exclusion; clock model."""

from dataclasses import replace

import numpy as np
import pytest

from inins.core import earth
from inins.core.flight import aircraft_trajectory
from inins.core.units import DEG
from inins.gnss import constellation, measurements, simulate, spp
from inins.gnss.spp import FixStatus

WEEK = 1826
T0 = 345600.0 + 5 * 3600.0


def _static(eph, n, rng, options, lat=37 * DEG, lon=127 * DEG, height=100.0):
    t = T0 + np.arange(float(n))
    pos, vel = simulate.static_receiver(lat, lon, height, n)
    bias, drift = simulate.clock_random_walk(t, 2e-19, 2e-20, rng, bias0=3.0e4, drift0=50.0)
    return simulate.simulate(eph, WEEK, t, pos, vel, bias, drift, rng, options)


@pytest.mark.parametrize("source", ["walker", "abpo"])
def test_noise_free_spp_recovers_position_and_clock(source, abpo_eph):
    eph = constellation.walker(WEEK, 345600.0, 86400.0) if source == "walker" else abpo_eph
    rng = np.random.default_rng(3)
    options = simulate.SimulationOptions(sigma_pr_m=0.0, sigma_rate_mps=0.0)
    obs, truth = _static(eph, 50, rng, options)
    sol = spp.solve(measurements.attach_satellites(obs, eph), spp.SppOptions(exclude_faults=False))
    assert (sol.n_used >= 5).all()
    assert np.linalg.norm(sol.pos - truth.pos, axis=1).max() < 1e-3  # m
    assert np.abs(sol.clock - truth.clock).max() < 1e-9 * 299792458.0  # 1 ns
    assert np.abs(sol.vel - truth.vel).max() < 1e-6
    assert np.abs(sol.drift - truth.drift).max() < 1e-6


def test_noise_free_spp_on_a_moving_aircraft_with_lever_arm():
    traj = aircraft_trajectory()
    t_rel = np.arange(0.0, 600.0, 2.0)
    lever = np.array([2.0, 0.5, -1.5])
    pos, vel = simulate.antenna_from_trajectory(traj, t_rel, lever)
    pos0, _ = simulate.antenna_from_trajectory(traj, t_rel)
    arm = np.linalg.norm(pos - pos0, axis=1)
    np.testing.assert_allclose(arm, np.linalg.norm(lever), rtol=1e-9)
    # antenna velocity = finite difference of antenna position
    ahead, _ = simulate.antenna_from_trajectory(traj, t_rel + 1e-3, lever)
    behind, _ = simulate.antenna_from_trajectory(traj, t_rel - 1e-3, lever)
    assert np.abs((ahead - behind) / 2e-3 - vel).max() < 1e-4
    eph = constellation.walker(WEEK, T0, 3600.0)
    rng = np.random.default_rng(4)
    bias, drift = simulate.clock_random_walk(T0 + t_rel, 2e-19, 2e-20, rng)
    obs, truth = simulate.simulate(
        eph,
        WEEK,
        T0 + t_rel,
        pos,
        vel,
        bias,
        drift,
        rng,
        simulate.SimulationOptions(sigma_pr_m=0.0, sigma_rate_mps=0.0),
    )
    sol = spp.solve(measurements.attach_satellites(obs, eph))
    assert np.linalg.norm(sol.pos - truth.pos, axis=1).max() < 1e-3
    assert np.abs(sol.clock - truth.clock).max() < 0.3
    assert np.linalg.norm(sol.vel - truth.vel, axis=1).max() < 1e-5
    assert np.linalg.norm(vel, axis=1).max() > 40.0  # it does move


def test_noisy_scatter_matches_pdop_times_sigma():
    """Unweighted LS with white noise sigma: E|dr|^2 = PDOP^2 sigma^2 per epoch."""
    eph = constellation.walker(WEEK, 345600.0, 86400.0)
    sigma = 2.0
    rng = np.random.default_rng(5)
    obs, truth = _static(eph, 500, rng, simulate.SimulationOptions(sigma_pr_m=sigma))
    sol = spp.solve(
        measurements.attach_satellites(obs, eph),
        spp.SppOptions(elevation_weights=False, sigma_zenith_m=sigma),
    )
    err2 = np.sum((sol.pos - truth.pos) ** 2, axis=1)
    ratio = np.sqrt(np.mean(err2 / (sol.pdop * sigma) ** 2))
    assert abs(ratio - 1.0) < 0.2  # 0.99 measured
    assert np.all(sol.pdop > 1.0)


def test_a_100_m_fault_is_excluded_and_named(abpo_eph):
    rng = np.random.default_rng(6)
    opts = simulate.SimulationOptions(sigma_pr_m=0.5, elevation_noise=True)
    obs, truth = _static(abpo_eph, 40, rng, opts, lat=-18.9 * DEG, lon=47.2 * DEG, height=1500.0)
    counts = np.diff(obs.start)
    assert counts.min() >= 6
    # one satellite per epoch, a different one each time, gets +100 m
    row = obs.start[:-1] + np.arange(len(counts)) % counts
    bad = obs.pseudorange.copy()
    bad[row] += 100.0
    eps = measurements.attach_satellites(replace(obs, pseudorange=bad), abpo_eph)
    sol = spp.solve(eps, spp.SppOptions(sigma_zenith_m=0.5))
    assert (sol.status == FixStatus.FAULT_EXCLUDED).all()
    np.testing.assert_array_equal(sol.excluded_prn, obs.prn[row])
    assert np.linalg.norm(sol.pos - truth.pos, axis=1).max() < 10.0
    assert not sol.used[row].any()
    clean = spp.solve(
        measurements.attach_satellites(obs, abpo_eph), spp.SppOptions(sigma_zenith_m=0.5)
    )
    assert (clean.excluded_prn == 0).sum() >= 38  # false alarms at 1e-3 are rare


def test_five_satellites_detect_but_cannot_name(abpo_eph):
    rng = np.random.default_rng(7)
    obs, _ = _static(
        abpo_eph,
        5,
        rng,
        simulate.SimulationOptions(sigma_pr_m=0.3),
        lat=-18.9 * DEG,
        lon=47.2 * DEG,
    )
    keep = np.zeros(len(obs.prn), bool)
    for k in range(obs.n_epochs):
        keep[obs.start[k] : obs.start[k] + 5] = True
    five = obs.take_rows(keep)
    bad = five.pseudorange.copy()
    bad[five.start[:-1]] += 100.0
    sol = spp.solve(
        measurements.attach_satellites(replace(five, pseudorange=bad), abpo_eph),
        spp.SppOptions(sigma_zenith_m=0.3, elevation_weights=False),
    )
    assert (sol.status == FixStatus.FAULT_DETECTED).all()
    assert (sol.excluded_prn == 0).all()


def test_fewer_than_four_satellites_is_a_recorded_no_fix(abpo_eph):
    rng = np.random.default_rng(8)
    obs, _ = _static(abpo_eph, 4, rng, simulate.SimulationOptions(sigma_pr_m=0.3))
    keep = np.ones(len(obs.prn), bool)
    keep[obs.start[1] + 3 : obs.start[2]] = False  # epoch 1 keeps 3 satellites
    keep[obs.start[2] : obs.start[3]] = False  # epoch 2 keeps none
    sol = spp.solve(measurements.attach_satellites(obs.take_rows(keep), abpo_eph))
    np.testing.assert_array_equal(
        sol.status, [FixStatus.FIX, FixStatus.NO_FIX, FixStatus.NO_FIX, FixStatus.FIX]
    )
    assert np.isnan(sol.pos[1:3]).all() and np.isnan(sol.pdop[1:3]).all()


def test_clock_random_walk_variance_matches_allan_parameters():
    """Drift variance 2 pi^2 h_-2 t and bias variance (h0/2) t + (2/3) pi^2 h_-2 t^3."""
    h0, h_2, step, n, runs = 2e-19, 2e-20, 1.0, 101, 4000
    t = np.arange(n) * step
    rng = np.random.default_rng(9)
    ends = np.array([simulate.clock_random_walk(t, h0, h_2, rng) for _ in range(runs)])[:, :, -1]
    c = 299792458.0
    tt = t[-1]
    var_bias = (h0 / 2 * tt + 2 / 3 * np.pi**2 * h_2 * tt**3) * c**2
    var_drift = 2 * np.pi**2 * h_2 * tt * c**2
    # sample variance of 4000 normal draws: relative standard error 2.2 %
    assert np.var(ends[:, 0]) == pytest.approx(var_bias, rel=0.1)
    assert np.var(ends[:, 1]) == pytest.approx(var_drift, rel=0.1)


def test_elevation_mask_and_visibility():
    eph = constellation.walker(WEEK, 345600.0, 86400.0)
    rng = np.random.default_rng(10)
    lat, lon = 37 * DEG, 127 * DEG
    obs, truth = _static(eph, 3, rng, simulate.SimulationOptions(mask_rad=20 * DEG), lat, lon)
    sol = spp.solve(measurements.attach_satellites(obs, eph), spp.SppOptions(mask_rad=0.0))
    assert np.nanmin(sol.elevation) >= 20 * DEG - 1e-6
    assert earth.llh_from_ecef(truth.pos[0])[2] == pytest.approx(100.0, abs=1e-6)


def test_doppler_sign_convention():
    """Doppler (Hz) = -range rate / lambda_L1: an approaching satellite has positive Doppler."""
    from inins.gnss.propagation import LAMBDA_L1

    rate = np.array([-500.0, 0.0, 300.0])
    np.testing.assert_allclose(measurements.range_rate_from_doppler(-rate / LAMBDA_L1), rate)
    obs = measurements.from_code(
        [WEEK],
        [T0],
        [0, 3],
        [1, 2, 3],
        [2.1e7, np.nan, 2.3e7],
        [2.1e7 + 3.0, np.nan, np.nan],
        [np.nan, 2.2e7, 2.2e7],
        doppler_l1=[1000.0, 0.0, -1000.0],
    )
    np.testing.assert_array_equal(
        obs.signal, [measurements.Signal.IONO_FREE, measurements.Signal.L1, measurements.Signal.L1]
    )
    np.testing.assert_allclose(
        obs.pseudorange, [2.1e7 - 3.0 / (1.6469 - 1.0), 2.2e7, 2.3e7], rtol=0, atol=0.01
    )
    assert obs.range_rate[0] < 0 < obs.range_rate[2]


def test_klobuchar_delay_is_simulated_and_removed():
    alpha = np.array([1.1176e-8, 7.4506e-9, -5.9605e-8, -5.9605e-8])
    beta = np.array([9.0112e4, 4.9152e4, -1.3107e5, -3.2768e5])
    eph = constellation.walker(WEEK, 345600.0, 86400.0)
    rng = np.random.default_rng(11)
    t0 = 345600.0 + 6 * 3600.0  # local afternoon at 127 deg E: ionosphere near its peak
    opts = simulate.SimulationOptions(sigma_pr_m=0.0, sigma_rate_mps=0.0, klobuchar=(alpha, beta))
    t = t0 + np.arange(10.0)
    pos, vel = simulate.static_receiver(37 * DEG, 127 * DEG, 100.0, len(t))
    obs, truth = simulate.simulate(eph, WEEK, t, pos, vel, np.zeros(10), np.zeros(10), rng, opts)
    epochs = measurements.attach_satellites(obs, eph)
    modelled = spp.solve(epochs, spp.SppOptions(klobuchar=(alpha, beta)))
    ignored = spp.solve(epochs)
    assert np.linalg.norm(modelled.pos - truth.pos, axis=1).max() < 1e-3
    assert np.linalg.norm(ignored.pos - truth.pos, axis=1).min() > 2.0  # metres of ionosphere


def test_predict_reproduces_simulated_measurements_and_spp_residuals(
    abpo_eph, abpo_epochs, abpo_spp
):
    rng = np.random.default_rng(12)
    opts = simulate.SimulationOptions(sigma_pr_m=0.0, sigma_rate_mps=0.0)
    obs, truth = _static(abpo_eph, 20, rng, opts, lat=-18.9 * DEG, lon=47.2 * DEG)
    epochs = measurements.attach_satellites(obs, abpo_eph)
    e = obs.epoch
    pred = measurements.predict(epochs, truth.pos[e], truth.vel[e], truth.clock[e], truth.drift[e])
    assert np.abs(pred.pseudorange - obs.pseudorange).max() < 1e-6
    assert np.abs(pred.range_rate - obs.range_rate).max() < 1e-9
    # at the SPP solution of the real day, the residuals are the SPP's
    k = np.arange(0, abpo_epochs.obs.n_epochs, 50)
    sub = abpo_epochs.take_epochs(k)
    rows = sub.obs.epoch
    at = measurements.predict(sub, abpo_spp.pos[k][rows], 0.0, abpo_spp.clock[k][rows], 0.0)
    mine = abpo_spp.residual[abpo_epochs.obs.epoch_rows(k)]
    used = abpo_spp.used[abpo_epochs.obs.epoch_rows(k)]
    np.testing.assert_allclose((sub.obs.pseudorange - at.pseudorange)[used], mine[used], atol=1e-6)
