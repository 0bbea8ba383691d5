"""IMU-GNSS time offset: the turn-rate clock fit on a synthetic signal, and the loose
filter's offset state on the PSINS tc recording (SPP fixes as the loose measurement)."""

import math

import numpy as np
import pytest

from inins.core import earth, strapdown
from inins.core.units import DEG, UG
from inins.ekf import loose, sources, timeoffset
from tests.helpers import CONFIGS


def test_clock_fit_recovers_offset_and_rate():
    """Yaw rate of random turns seen on an IMU axis running 400 ppm slow, 2.5 s behind:
    the mapping within 10 ms over 590 s (measured 5.4 ms), the rate within 20 ppm."""
    rng = np.random.default_rng(3)
    t_g = np.arange(0.0, 600.0, 0.25)
    knots = np.arange(-20.0, 640.0, 4.0)
    rate = lambda t: np.interp(t, knots, rng_vals)  # noqa: E731
    rng_vals = 0.2 * rng.standard_normal(knots.size)
    t_i = np.arange(0.0, 590.0, 0.01)
    true_gnss = 2.5 + t_i * (1 - 400e-6)  # GNSS time of each IMU sample
    w_i = rate(true_gnss) + 0.01 * rng.standard_normal(t_i.size)
    windows = [(a, a + 60.0) for a in np.arange(20.0, 540.0, 60.0)]
    fit = timeoffset.fit_clock(t_i, w_i, t_g, rate(t_g), windows)
    print("fit", fit.offset, fit.offset_sigma, fit.rate, fit.rate_sigma)
    err = fit.to_gnss(t_i) - true_gnss
    print("mapping error max", np.abs(err).max())
    assert np.abs(err).max() < 0.01  # measured 5.4 ms (lag grid 2 ms, 4 Hz GNSS)
    assert abs(fit.rate + 400e-6) < 20e-6


def _turns(seed, rate_ppm, lag_noise=0.0):
    """Random turns seen by an IMU running ``rate_ppm`` fast (GNSS = 2.5 s + t_imu (1 +
    rate)); the GNSS course rate with a white lag error of ``lag_noise`` s per window
    (each window's GNSS signal shifted by its own error)."""
    rng = np.random.default_rng(seed)
    knots = np.arange(-20.0, 640.0, 4.0)
    vals = 0.2 * rng.standard_normal(knots.size)
    t_g = np.arange(0.0, 600.0, 0.25)
    t_i = np.arange(0.0, 590.0, 0.01)
    true_gnss = 2.5 + t_i * (1 + rate_ppm * 1e-6)
    w_i = np.interp(true_gnss, knots, vals)
    shift = lag_noise * rng.standard_normal(t_g.size // 240 + 1)[(t_g // 60).astype(int)]
    w_g = np.interp(t_g + shift, knots, vals)
    windows = [(a, a + 60.0) for a in np.arange(20.0, 540.0, 60.0)]
    return t_i, w_i, t_g, w_g, windows, true_gnss


def test_auto_model_is_a_constant_without_rate_and_a_line_with_one():
    """The default (auto) keeps the constant offset when the IMU clock has no rate error
    (the offset within 10 ms: measured 1e-8 s; rate not applied, t 0.40 below its
    threshold 3.50) and applies the line when it runs 400 ppm fast (t 85; the mapping within
    10 ms). A sign flip of the applied rate fails the second."""
    fit = timeoffset.fit_clock(*_turns(5, 0.0)[:5])
    print("zero rate", fit.model, fit.offset, fit.rate_test)
    assert fit.model == "constant" and fit.rate == 0.0
    assert fit.rate_test.t < fit.rate_test.threshold
    assert abs(fit.offset - 2.5) < 0.01
    assert fit.t_ref_gnss == pytest.approx(290.0, abs=1.0)  # mean window centre
    *args, true_gnss = _turns(5, 400.0)
    fit = timeoffset.fit_clock(*args)
    print("400 ppm", fit.model, fit.rate, fit.rate_test)
    assert fit.model == "line" and fit.rate_test.significant
    assert np.abs(fit.to_gnss(args[0]) - true_gnss).max() < 0.01
    fixed = timeoffset.fit_clock(*args, model="constant")
    assert fixed.model == "constant" and fixed.rate == 0.0
    assert np.abs(fixed.to_gnss(args[0]) - true_gnss).max() > 0.1  # 400 ppm x 295 s


def test_rate_test_false_alarms_at_its_stated_rate():
    """The t test on 8 window lags with white scatter and no rate: over 4000 seeds the
    fraction taken for a rate is the false-alarm probability asked (0.05 within 3
    binomial sigma, +-0.010; at 0.01 within +-0.005); a rate of 5 sigma is found in
    most (> 80 %: measured 0.99). A one-sided or a
    normal threshold instead of the two-sided Student one fails the first."""
    rng = np.random.default_rng(11)
    x = np.arange(8) * 60.0
    x = x - x.mean()
    for alpha, tol in ((0.05, 0.010), (0.01, 0.005)):
        hits = [
            timeoffset.line_fit(x, 0.1 * rng.standard_normal(8), alpha)[2].significant
            for _ in range(4000)
        ]
        print(alpha, np.mean(hits))
        assert abs(np.mean(hits) - alpha) < tol
    sigma_b = 0.1 / math.sqrt(np.sum(x**2))
    hits = [
        timeoffset.line_fit(x, 5 * sigma_b * x + 0.1 * rng.standard_normal(8), 0.05)[2].significant
        for _ in range(1000)
    ]
    print("power", np.mean(hits))
    assert np.mean(hits) > 0.8


def test_course_rate_is_clockwise_from_north():
    """A velocity turning from north towards east at 0.1 rad/s (the heading's sense, spec
    §2): course rate +0.1 rad/s; below ``min_speed`` zero."""
    t = np.arange(0.0, 20.0, 0.5)
    course = 0.3 + 0.1 * t
    speed = np.where(t < 5.0, 1.0, 10.0)
    vel = np.stack([speed * np.cos(course), speed * np.sin(course), np.zeros_like(t)], -1)
    rate = timeoffset.course_rate(t, vel, min_speed=3.0)
    np.testing.assert_allclose(rate[t > 6.0], 0.1, rtol=1e-9)
    assert not rate[t < 5.0].any()


@pytest.mark.slow
def test_psins_tc_time_offset():
    """The PSINS tc drive (136 s, real MEMS at 200 Hz): its SPP fixes (0.3 m position
    sigma, the time-averaged NIS ~0.1-0.7 per axis) through the loose filter with the
    offset state. Measured: positions only 0.387 +- 0.044 s; with the SPP range-rate
    velocities (0.12 m/s, f_b averaged over 0.2 s for the acceleration in H) 0.214 +-
    0.024 s. The issue's same-sign range-rate misfits suggested 0.2-0.4 s: both land
    there, but they differ by 3.5 combined sigma (pseudorange and Doppler not
    time-consistent in this recording, or the MEMS acceleration noise; not resolved).
    Asserted: positions only within 0.3-0.5 s and sigma < 0.06 s."""
    from inins.gnss import ephemeris, measurements, spp
    from inins.io.psins_tc import read_psins_tc

    path = CONFIGS.parent / "data" / "insgpseo_tc.mat"
    rec = read_psins_tc(path)
    imu = rec.imu
    dt = float(np.median(np.diff(imu.time)))
    obs = measurements.from_record(rec.gnss)
    t = obs.time - rec.imu_t0_sow
    inside = np.flatnonzero((t > imu.time[0] - 1.0) & (t < imu.time[-1] + 1.0))
    eph = ephemeris.from_columns(rec.ephemeris)
    epochs = measurements.attach_satellites(obs.take_epochs(inside), eph)
    t = epochs.obs.time - rec.imu_t0_sow
    klob = None if rec.iono_alpha is None else (rec.iono_alpha, rec.iono_beta)
    fix = spp.solve(epochs, spp.SppOptions(mask_rad=10 * DEG, klobuchar=klob))
    ok = np.isfinite(fix.pos[:, 0])
    lla = earth.llh_from_ecef(fix.pos[ok])
    vel_n = np.einsum("ji,nj->ni", earth.mat_en(lla[0, 0], lla[0, 1]), fix.vel[ok])
    init = sources.velocity_heading(
        imu.time, imu.dtheta, imu.dv, dt, lla[0], (0.0, 69.5), t[ok], vel_n, 1.5
    )
    nav0 = strapdown.NavState.from_attitude(init.mat_nb, np.zeros(3), lla[0])
    sol = loose.GnssSolution(t[ok], lla, np.full((ok.sum(), 3), 0.3))
    sigma0 = [5.0] * 3 + [0.1] * 3 + [DEG, DEG, 5 * DEG] + [2000 * UG] * 3 + [20 * DEG / 3600] * 3
    cfg = loose.LooseConfig(
        dt=dt,
        arw=np.full(3, 0.3 * DEG / 60),
        vrw=np.full(3, 300 * UG),
        gyro_bias_rw=np.full(3, 2 * DEG / 3600),
        accel_bias_rw=np.full(3, 10 * UG),
        sigma0=np.array(sigma0),
        time_offset=True,
        time_offset_sigma=0.5,
        gate_probability=1.0,
        window=40,
    )
    run = loose.run_loose(
        cfg, nav0, float(imu.time[0] - dt), lambda a, b: (imu.dtheta[a:b], imu.dv[a:b]), sol
    )
    est, sig = run.x[-1, 15], math.sqrt(run.P[-1, 15, 15])
    print("PSINS tc time offset", est, sig)
    assert 0.3 < est < 0.5
    assert sig < 0.06
