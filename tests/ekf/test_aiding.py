"""Vehicle aiding of the loose filter: ZUPT on a stop-and-go drive, NHC in outages, the
stationary detector."""

import numpy as np
import pytest
from test_loose_smoother import DT, LEVER, _config, _errors, _sigma0

from inins.core import error_model
from inins.core.units import DEG, DPH, UG
from inins.ekf import aiding, drive, loose, outages


def _sim(plan, seed, errors):
    return drive.simulate_drive(
        plan,
        errors,
        DT,
        seed,
        lever=LEVER,
        sigma_ned=(0.5, 0.5, 1.0),
        init_attitude=(0.5 * DEG, 0.5 * DEG, 2 * DEG),
        init_pos=0.1,
        init_vel=0.05,
    )


def _stops(d, duration, threshold=0.002):
    """Windows (s) where the true speed is below ``threshold`` (after the start)."""
    t = np.arange(0.0, duration, 0.1)
    _, v, _ = d.truth.state(t)
    st = np.linalg.norm(v, axis=1) < threshold
    out, on = [], None
    for i in range(1, t.size):
        if st[i] and not st[i - 1]:
            on = t[i]
        if not st[i] and st[i - 1] and on is not None:
            out.append((float(on), float(t[i - 1])))
    return out


@pytest.mark.slow
def test_zupt_on_stop_and_go_holds_velocity_below_1_cm_s():
    """Three 11 s stops (true speed < 2 mm/s) of a 5 m/s stop-and-go drive, 10 deg/h,
    1 mg unit, 0.5 m GNSS. Measured max velocity error while stopped: without ZUPT
    55.6 mm/s, with ZUPT (3 mm/s) + ZARU 4.7 mm/s. Asserted: < 10 mm/s with, > 20 without."""
    errors = _errors(np.random.default_rng(11), gyro=10 * DPH, accel=1000 * UG)
    plan = drive.city_plan(400, speed=5.0, stop_every=40, stop_s=80)
    d = _sim(plan, 11, errors)
    stops = _stops(d, plan.duration)
    assert len(stops) == 3
    worst = []
    for zupt in (0.0, 0.003):
        cfg = _config(
            sigma0=_sigma0(10 * DPH, 1000 * UG), zupt_sigma=zupt, zaru_sigma=1e-4 if zupt else 0
        )
        run = loose.run_loose(cfg, d.initial, 0.0, d.imu, d.solution, stationary_windows=stops)
        _, vel, _, _, _ = run.output()
        _, v_true, _ = d.truth.state(run.time)
        inside = np.zeros(run.time.size, bool)
        for a, b in stops:
            inside |= (run.time >= a) & (run.time < b)
        worst.append(np.linalg.norm(vel - v_true, axis=1)[inside].max())
    assert worst[1] < 0.01 < 0.02 < worst[0]


def test_nhc_bounds_lateral_drift_in_outages():
    """60 s outages every 120 s, 10 deg/h, 1 mg unit. Measured max lateral (body y)
    position error inside the outages: without NHC 23.5 m, with NHC (0.05 m/s) 0.63 m;
    max-drift RMS 14.8 m -> 2.8 m. Asserted: lateral < 1/10 of without and < 1.5 m."""
    errors = _errors(np.random.default_rng(11), gyro=10 * DPH, accel=1000 * UG)
    plan = drive.city_plan(400, stop_every=80, stop_s=20)
    d = _sim(plan, 11, errors)
    win = outages.periodic_windows(0.0, d.solution.time[-1], 120.0, 60.0, first=100.0)
    lateral, drift = [], []
    for nhc in (0.0, 0.05):
        cfg = _config(sigma0=_sigma0(10 * DPH, 1000 * UG), nhc_sigma=nhc)
        run = loose.run_loose(cfg, d.initial, 0.0, d.imu, d.solution, outages=win)
        _, _, lla, _, _ = run.output()
        mat, _, ref = d.truth.state(run.time)
        err = error_model.position_error_ned(lla, ref)
        body = np.einsum("kji,kj->ki", mat, err)
        inside = np.zeros(run.time.size, bool)
        for a, b in win:
            inside |= (run.time >= a) & (run.time < b)
        lateral.append(np.abs(body[inside, 1]).max())
        drift.append(outages.score(run.time, lla, None, ref, None, win).rms_horizontal)
    assert lateral[1] < 0.1 * lateral[0]
    assert lateral[1] < 1.5
    assert drift[1] < 0.5 * drift[0]


def test_stationary_detector_statistic():
    """Noise at rest passes; a 0.2 m/s^2 acceleration step or a 2 deg/s turn does not."""
    rng = np.random.default_rng(0)
    dt, n = 0.01, 300
    f = np.tile([0.0, 0.0, -9.81], (n, 1)) + 0.01 * rng.standard_normal((n, 3))
    w = 1e-4 * rng.standard_normal((n, 3))
    ends = np.array([100, 200, 300])
    f[150:200, 0] += np.linspace(0, 0.4, 50)  # accelerating in the 2nd window
    w[250:, 2] += 2 * DEG  # turning in the 3rd
    flags = aiding.stationary(w * dt, f * dt, dt, ends, 50)
    assert list(flags) == [True, False, False]
    # each window on its own samples: at rest after a turn and an acceleration is at rest
    f[150:200, 0] = f[0:50, 0]
    w[:, 2] = w[::-1, 2]  # the turn first (samples 0-49), then at rest
    flags = aiding.stationary(w * dt, f * dt, dt, np.array([50, 100, 300]), 50)
    assert list(flags) == [False, True, True]


def test_odometer_bounds_along_track_drift_in_outages():
    """The NHC drive with a wheel odometer (true forward speed + 2 cm/s white noise, no
    scale error). Measured max along-track (body x) error inside the 60 s outages: NHC
    only 4.22 m, NHC + odometer (0.05 m/s) 0.24 m. Asserted: with < 1/3 of without."""
    errors = _errors(np.random.default_rng(11), gyro=10 * DPH, accel=1000 * UG)
    plan = drive.city_plan(400, stop_every=80, stop_s=20)
    d = _sim(plan, 11, errors)
    win = outages.periodic_windows(0.0, d.solution.time[-1], 120.0, 60.0, first=100.0)
    t_odo = np.arange(0.0, plan.duration, 0.1)
    mat, vel, _ = d.truth.state(t_odo)
    speed = np.einsum("kji,kj->ki", mat, vel)[:, 0]
    speed = speed + 0.02 * np.random.default_rng(1).standard_normal(speed.size)
    along = []
    for odo_sigma in (0.0, 0.05):
        cfg = _config(sigma0=_sigma0(10 * DPH, 1000 * UG), nhc_sigma=0.05, odometer_sigma=odo_sigma)
        run = loose.run_loose(
            cfg, d.initial, 0.0, d.imu, d.solution, outages=win, odometer=(t_odo, speed)
        )
        _, _, lla, _, _ = run.output()
        m_t, _, ref = d.truth.state(run.time)
        body = np.einsum("kji,kj->ki", m_t, error_model.position_error_ned(lla, ref))
        inside = np.zeros(run.time.size, bool)
        for a, b in win:
            inside |= (run.time >= a) & (run.time < b)
        along.append(np.abs(body[inside, 0]).max())
    assert along[1] < along[0] / 3.0
