"""The outlier gate of the loosely coupled filter's fixes (:mod:`inins.ekf.gate`): its
bound against scipy's chi-square quantile, the NIS of a fix, the re-initialisation as
the limit of an update from an infinite prior, the spike screen of a solution series,
and on a simulated drive: one bad fix rejected, a genuine jump re-initialised after
``reinit_after`` rejected epochs (and rejected forever without it)."""

import math

import numpy as np
import pytest
from scipy import stats

from inins.core import error_model, imu
from inins.core.units import DEG, DPH, UG
from inins.ekf import drive, gate, loose
from inins.exceptions import InputError

DT = 0.02
LEVER = (0.5, 0.2, -1.2)
ARW, VRW = 0.1 * DEG / 60, 0.1 / 60


@pytest.mark.parametrize("p", [0.99, 0.9999, 0.999999])
@pytest.mark.parametrize("k", [1.0, 10.0])
def test_bound_is_the_scaled_chi_square_quantile(p, k):
    """k^2 times scipy's chi-square(3) quantile; 3 degrees of freedom, not 1."""
    assert gate.bound(p, k) == pytest.approx(k**2 * stats.chi2.ppf(p, 3), rel=1e-10)
    assert gate.bound(p, k, dof=1) == pytest.approx(k**2 * stats.chi2.ppf(p, 1), rel=1e-10)
    assert gate.bound(1.0, k) == math.inf
    assert gate.bound(0.999999, 1.0) == pytest.approx(30.66, abs=0.01)


def test_nis_of_a_fix_is_y_s_inverse_y():
    rng = np.random.default_rng(1)
    A = rng.normal(size=(6, 6))
    P = A @ A.T + np.eye(6)
    H = rng.normal(size=(3, 6))
    y, r = rng.normal(size=3), np.array([0.1, 0.2, 0.3])
    S = H @ P @ H.T + np.diag(r)
    assert gate.nis(P, H, y, r) == pytest.approx(y @ np.linalg.solve(S, y), rel=1e-12)


def test_reinitialise_is_the_update_from_an_infinite_prior():
    """Against the Kalman update with the re-initialised states' prior variance at 1e8:
    the state takes the fix (x_J - y, not + y) with the fix's variance plus what the
    other states carry through H_o, and the logged prediction gains the jump."""
    rng = np.random.default_rng(2)
    n, states = 7, np.array([0, 1, 2])
    A = rng.normal(size=(n, n)) * 0.1
    P = A @ A.T + 0.01 * np.eye(n)
    H = np.zeros((3, n))
    H[:, states] = -np.eye(3)
    H[:, 3:6] = rng.normal(size=(3, 3)) * 0.5  # the lever arm's attitude columns, say
    H[:, 6] = [2.0, -1.0, 0.5]  # a time offset's column
    x = rng.normal(size=n) * 0.1
    y, r = np.array([30.0, -20.0, 5.0]), np.array([0.01, 0.02, 0.04])
    big = P.copy()
    big[np.ix_(states, states)] += 1e8 * np.eye(3)
    S = H @ big @ H.T + np.diag(r)
    K = big @ H.T @ np.linalg.inv(S)
    want_x = x + K @ y
    want_P = (np.eye(n) - K @ H) @ big
    got_x, got_P, pred = x.copy(), P.copy(), P.copy()
    gate.reinitialise(got_x, got_P, pred, H, y, r, states)
    np.testing.assert_allclose(got_x, want_x, atol=1e-6)
    np.testing.assert_allclose(got_P, want_P, atol=1e-6)
    np.testing.assert_allclose(got_x[states], x[states] - y)
    np.testing.assert_allclose(np.diag(pred)[:3] - np.diag(P)[:3], gate.JUMP_SCALE * (y**2 + r))
    np.testing.assert_array_equal(pred[3:, 3:], P[3:, 3:])


def _series(m=200, dt=0.25):
    """A car's positions (NED m) turning at 0.2 rad/s and 15 m/s, 1 cm sigma."""
    t = np.arange(m) * dt
    pos = np.stack([75 * np.sin(0.2 * t), 75 * (1 - np.cos(0.2 * t)), 0.01 * t], 1)
    return t, pos, np.full((m, 3), 1e-4)


def test_spikes_flag_a_spike_not_a_jump_nor_a_turn():
    t, pos, var = _series()
    limit = gate.bound(0.999999, 10.0)
    assert not gate.spikes(t, pos, var, limit).any()  # 2.9 m/s^2 of turning
    spiky = pos.copy()
    spiky[50, 0] += 100.0
    spiky[120:122, 1] -= 400.0  # a two-epoch burst (40 m would be the filter gate's: 22 sigma)
    assert np.flatnonzero(gate.spikes(t, spiky, var, limit)).tolist() == [50, 120, 121]
    jump = pos.copy()
    jump[80:, 0] += 100.0  # a genuine jump: fails from before, not from after
    assert not gate.spikes(t, jump, var, limit).any()
    assert not gate.spikes(t, spiky, var, math.inf).any()  # the gate off


def test_spike_bound_sits_at_the_limit():
    """A spike just above the bound is flagged, just below it not (the allowance of 1 g
    between 4 Hz epochs, 0.31 m, dominates the variance)."""
    t, pos, var = _series()
    t, pos = t[:20], pos[:20] * 0.0  # standing still
    var = var[:20]
    limit = 100.0
    one = 0.5 * gate.VEHICLE_ACCEL * 0.25 * 0.5  # the line's allowance over 0.25, 0.5 s
    size = math.sqrt(limit * (one**2 + 1e-4 * (1 + 4 + 1)))
    for factor, flagged in ((1.01, True), (0.99, False)):
        p = pos.copy()
        p[10, 0] = factor * size
        assert gate.spikes(t, p, var, limit)[10] == flagged


def test_screen_fails_above_the_limit():
    diff = np.array([[3.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    assert gate.screen(diff, np.ones((2, 3)), 5.0).tolist() == [True, False]


def _drive(seed=4, duration=120.0):
    errors = imu.SensorErrors(
        gyro_bias=np.random.default_rng(seed).normal(0, DPH, 3),
        accel_bias=np.random.default_rng(seed + 1).normal(0, 1000 * UG, 3),
        gyro_arw=ARW,
        accel_vrw=VRW,
    )
    return drive.simulate_drive(
        drive.city_plan(duration),
        errors,
        DT,
        seed,
        lever=LEVER,
        sigma_ned=(0.5, 0.5, 1.0),
        init_attitude=(0.5 * DEG, 0.5 * DEG, 2 * DEG),
        init_pos=0.1,
        init_vel=0.05,
    )


def _config(**kw):
    sigma0 = np.array([0.1] * 3 + [0.05] * 3 + [0.5 * DEG, 0.5 * DEG, 2 * DEG] + [1e-2] * 3)
    sigma0 = np.r_[sigma0, [DPH] * 3]
    return loose.LooseConfig(
        dt=DT, arw=np.full(3, ARW), vrw=np.full(3, VRW), lever_arm=LEVER, sigma0=sigma0, **kw
    )


def _moved(solution, start, shift_n, stop=None):
    """The solution with its positions moved ``shift_n`` m north on epochs start..stop."""
    lla = solution.lla.copy()
    sel = slice(start, stop)
    lla[sel] = error_model.lla_offset(lla[sel], np.array([shift_n, 0.0, 0.0]))
    return loose.GnssSolution(solution.time, lla, solution.sigma_ned)


def _error_n(d, run):
    _, _, lla, _, _ = run.output()
    return error_model.position_error_ned(lla, d.truth.state(run.time)[2])[:, 0]


@pytest.fixture(scope="module")
def sim():
    d = _drive()
    return d, loose.run_loose(_config(), d.initial, 0.0, d.imu, d.solution)


def test_one_bad_fix_is_rejected(sim):
    """A fix 1 km off (2000 sigma) is rejected by the default gate and the run goes on as
    the clean one less that fix (measured: 0.11 m apart at most; asserted within the
    fixes' 0.5 m sigma); without the gate it pulls the solution off by hundreds of
    metres."""
    d, clean = sim
    k = 60
    bad = _moved(d.solution, k, 1000.0, k + 1)
    run = loose.run_loose(_config(), d.initial, 0.0, d.imu, bad)
    assert np.flatnonzero(run.rejected[:, 0]).tolist() == [k]
    assert not run.reinit.any() and not clean.rejected.any()
    assert run.nis[k, 0] > gate.bound(0.999999, 10.0) > np.nanmax(clean.nis[:, 0])
    assert np.max(np.abs(_error_n(d, run) - _error_n(d, clean))) < 0.5
    no_gate = _config(outlier_probability=1.0, gate_probability=1.0)  # nor the per-row one
    off = loose.run_loose(no_gate, d.initial, 0.0, d.imu, bad)
    assert not off.rejected.any()
    assert np.max(np.abs(_error_n(d, off))) > 100.0


def test_a_genuine_jump_reinitialises_after_n_rejections(sim):
    """The solutions move 20 m north from epoch 60 on (40 sigma; a consistent simulated
    filter: sigma_scale 1). reinit_after 5: five epochs rejected, the sixth
    re-initialises position, and from there every fix is accepted and the estimate
    follows the moved solutions (north error 20 m +- 1 m at the end). With
    reinit_after beyond the run the gate rejects the next 45 fixes (measured), until the
    INS's sigma has grown to the jump, then takes them with the gain of a filter that
    coasted (5.2 m off the moved solutions at the end, against 0.1 m)."""
    d, _ = sim
    k = 60
    jump = _moved(d.solution, k, 20.0)
    cfg = _config(outlier_sigma_scale=1.0, reinit_after=5)
    run = loose.run_loose(cfg, d.initial, 0.0, d.imu, jump)
    assert np.flatnonzero(run.rejected[:, 0]).tolist() == list(range(k, k + 5))
    assert np.flatnonzero(run.reinit).tolist() == [k + 5]
    err = _error_n(d, run)
    assert abs(err[k + 5] - 20.0) < 2.0  # the estimate takes the solution: truth + 20 m north
    assert abs(err[-1] - 20.0) < 1.0
    never = loose.run_loose(
        _config(outlier_sigma_scale=1.0, reinit_after=100_000), d.initial, 0.0, d.imu, jump
    )
    assert never.rejected[k : k + 40, 0].all() and not never.reinit.any()
    assert abs(_error_n(d, never)[-1] - 20.0) > 2.0


def test_reinitialisation_cuts_the_smoother_across_the_jump(sim):
    """The smoothed solution before the jump stays on the old solutions (within 1 m of
    truth), after it on the new ones: the jump is not smeared back."""
    from inins.ekf import smoother

    d, _ = sim
    k = 60
    jump = _moved(d.solution, k, 20.0)
    run = loose.run_loose(
        _config(outlier_sigma_scale=1.0, reinit_after=5), d.initial, 0.0, d.imu, jump
    )
    sm = smoother.smooth(run)
    err = error_model.position_error_ned(sm.lla, d.truth.state(run.time)[2])[:, 0]
    assert np.max(np.abs(err[: k - 1])) < 1.0
    assert np.max(np.abs(err[k + 6 :] - 20.0)) < 1.5


@pytest.mark.parametrize(
    ("kw", "key"),
    [
        ({"outlier_probability": 0.3}, "outlier_probability"),
        ({"outlier_sigma_scale": 0.5}, "outlier_sigma_scale"),
        ({"reinit_after": 0}, "reinit_after"),
    ],
)
def test_gate_settings_are_checked(kw, key):
    with pytest.raises(InputError) as err:
        _config(**kw)
    assert err.value.key == key
