"""Strapdown integrator against exact truth, closed forms and the linear phi-angle error model."""

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import curve_fit

from inins.core import earth, error_model, flight, rotation
from inins.core import strapdown as sd
from inins.core import trajectory as tr
from inins.core.units import ARCMIN, ARCSEC, DEG, DPH, MINUTE

LAT, LON, HEIGHT = 37.0 * DEG, 127.0 * DEG, 300.0
DT = 0.005


def _start(truth):
    mat_nb, vel_n, lla = truth.state([0.0])
    return sd.NavState.from_attitude(mat_nb[0], vel_n[0], lla[0])


def _navigate(truth, n, dt=DT, gyro_bias=None, increments=None, **options):
    """Integrate exact increments; return the series and its errors against truth."""
    if increments is None:
        increments = tr.ideal_increments(truth, np.arange(n + 1) * dt)
    dtheta, dv = increments
    if gyro_bias is not None:
        dtheta = dtheta + np.asarray(gyro_bias) * dt
    _, series = sd.integrate(_start(truth), dtheta, dv, dt, **options)
    mat_nb, vel_n, lla = truth.state(series.time(dt))
    phi = error_model.attitude_error(series.mat_nb(), mat_nb)
    return series, phi, series.vel_n - vel_n, error_model.position_error_ned(series.lla, lla)


def _phi_model(lat, height, size):
    """Stationary phi-angle error model F (NED) on [phi, dv], [.., dlat, dlon], [.., dh].

    ``size`` 6: position held; 8: height held; 9: free.
    """
    rn, re = earth.principal_radii(lat)
    w_ie = earth.rate_ie_n(lat)
    f = np.zeros((size, size))
    f[0:3, 0:3] = -rotation.skew(w_ie)
    f[3:6, 0:3] = rotation.skew([0.0, 0.0, -earth.gravity(lat, height)])  # f_n x phi
    f[3:6, 3:6] = -2.0 * rotation.skew(w_ie)
    if size > 6:  # transport-rate and Earth-rate errors from dv, dlat
        f[0:3, 3:6] = [
            [0, 1 / (re + height), 0],
            [-1 / (rn + height), 0, 0],
            [0, -np.tan(lat) / (re + height), 0],
        ]
        f[0:3, 6] = earth.RATE * np.array([-np.sin(lat), 0.0, -np.cos(lat)])
        f[6, 3], f[7, 4] = 1 / (rn + height), 1 / ((re + height) * np.cos(lat))
    if size > 8:  # gravity gradient: dv_D' = (dg/dh) dh, dh' = -dv_D
        f[5, 8] = (earth.gravity(lat, height + 1.0) - earth.gravity(lat, height - 1.0)) / 2.0
        f[8, 5] = -1.0
    return f


def test_stationary_hour_free_navigation_is_exact():
    truth = tr.Stationary(LAT, LON, HEIGHT, rotation.mat_from_euler(0.01, -0.02, 1.0))
    _, phi, dvel, dpos = _navigate(truth, 720_000, decimation=2000)
    assert np.abs(dpos[:, :2]).max() < 0.01  # m (measured ~1e-9 m)
    assert np.abs(phi).max() < 0.01 * ARCSEC  # measured ~2e-5 arcsec
    assert np.abs(dvel).max() < 1e-5  # m/s


def test_moving_trajectory_with_turns():
    truth = flight.aircraft_trajectory()  # 10 min, 50-150 m/s, bank +-30 deg, climbs
    increments = tr.ideal_increments(truth, np.arange(120_001) * DT)
    series, phi, dvel, dpos = _navigate(truth, 0, increments=increments, decimation=200)
    assert len(series) == 600
    assert np.abs(dpos).max() < 0.05  # m, spec bound 0.5 m (measured 4.1e-3 m, vertical)
    assert np.abs(dpos[:, :2]).max() < 0.005  # m (measured 5.4e-4 m)
    assert np.abs(dvel).max() < 2e-4  # m/s (measured 1.6e-5 m/s)
    assert np.abs(phi).max() < 1e-3 * ARCSEC  # measured 1.7e-5 arcsec
    # the corrections matter on this trajectory: without them the errors are far larger
    _, phi_raw, _, dpos_raw = _navigate(
        truth, 0, increments=increments, decimation=200, coning=False, sculling=False
    )
    assert np.abs(phi_raw).max() > 100 * np.abs(phi).max()
    assert np.abs(dpos_raw[:, :2]).max() > 10 * np.abs(dpos[:, :2]).max()
    # second order: halving the rate multiplies the errors by 4
    _, phi_half, _, dpos_half = _navigate(truth, 60_000, dt=2 * DT, decimation=100)
    assert 3.6 < np.abs(dpos_half).max() / np.abs(dpos).max() < 4.4
    assert 3.6 < np.abs(phi_half).max() / np.abs(phi).max() < 4.6


def test_coning_drift_matches_closed_form():
    theta, freq = 1.0 * DEG, 5.0
    truth = tr.Coning(theta, freq, LAT, LON, HEIGHT)  # cone axis north
    rates = {}
    for corrected in (False, True):
        series, phi, _, _ = _navigate(
            truth, 12_000, fixed_position=True, coning=corrected, decimation=100
        )
        rates[corrected] = np.polyfit(series.time(DT), phi[:, 0], 1)[0]  # rad/s
        expected = sd.coning_drift_rate(theta, freq, DT, corrected)
        assert rates[corrected] == pytest.approx(expected, rel=0.01)
    # uncorrected ~4 arcsec/s here; the two-sample correction removes ~99.5 %
    assert rates[False] > 200 * rates[True] > 0.0


def test_schuler_oscillation_period():
    lat, height, dt = LAT, HEIGHT, 0.1
    truth = tr.Stationary(lat, LON, height)
    dtheta, dv = tr.ideal_increments(truth, np.arange(108_001) * dt)  # 3 h
    tilt = sd.NavState.from_attitude(
        rotation.mat_from_rotvec([ARCMIN, 0, 0]), [0, 0, 0], [lat, LON, height]
    )
    # vertical channel held: the free one diverges (e-folding ~9.5 min) from the
    # -g phi^2 / 2 vertical error of the tilt and would swamp the 3-h record
    _, series = sd.integrate(tilt, dtheta, dv, dt, fixed_height=True, decimation=100)
    t, v_east = series.time(dt), series.vel_n[:, 1]

    # Schuler pair split by the Foucault rate, plus the 24-h and constant modes
    def model(t, w1, w2, *c):
        return (
            c[0] * np.sin(w1 * t)
            + c[1] * np.cos(w1 * t)
            + c[2] * np.sin(w2 * t)
            + c[3] * np.cos(w2 * t)
            + c[4]
            + c[5] * t
            + c[6] * np.sin(earth.RATE * t)
            + c[7] * np.cos(earth.RATE * t)
        )

    w_s, w_f = 2.0 * np.pi / (84.4 * MINUTE), earth.RATE * np.sin(lat)
    p, _ = curve_fit(model, t, v_east, p0=[w_s - w_f, w_s + w_f] + [0.0] * 8)
    period = 2.0 * np.pi / np.mean(p[:2]) / MINUTE
    assert abs(period - 84.4) < 0.5, period  # measured 84.23 min
    eig = np.linalg.eigvals(_phi_model(lat, height, 8))
    modes = np.sort(eig.imag[eig.imag > 1e-4])  # Schuler +- Foucault (rad/s)
    assert abs(period - 2.0 * np.pi / np.mean(modes) / MINUTE) < 0.05
    # the whole velocity record follows the linear phi-angle model
    x0 = np.zeros(8)
    x0[0] = -ARCMIN  # mat_est = exp([r x]) mat_nb  <=>  phi = -r
    lin = np.array([expm(_phi_model(lat, height, 8) * s)[3:5] @ x0 for s in t[::30]])
    amplitude = np.abs(series.vel_n[:, 1]).max()  # ~2.3 m/s
    assert np.abs(series.vel_n[::30, :2] - lin).max() < 1e-3 * amplitude


def test_free_vertical_channel_diverges_with_gravity_gradient():
    truth = tr.Stationary(LAT, LON, HEIGHT)
    dt = 0.1
    dtheta, dv = tr.ideal_increments(truth, np.arange(18_001) * dt)  # 30 min
    start = sd.NavState.from_attitude(np.eye(3), [0.0, 0.0, 0.01], [LAT, LON, HEIGHT])
    _, series = sd.integrate(start, dtheta, dv, dt, decimation=600)
    t, dh = series.time(dt), series.lla[:, 2] - HEIGHT
    model = _phi_model(LAT, HEIGHT, 9)
    lin = np.array([expm(model * s)[8, 5] * 0.01 for s in t])
    assert np.abs(dh - lin).max() < 1e-4 * np.abs(lin).max()  # measured -66.83 m at 30 min
    tau = 1.0 / np.sqrt(-model[5, 8])  # ~569 s: dh ~ -v0 tau sinh(t / tau) uncoupled
    assert dh[-1] == pytest.approx(-0.01 * tau * np.sinh(t[-1] / tau), rel=0.01)


def test_fixed_position_stationary_is_exact():
    truth = tr.Stationary(LAT, LON, HEIGHT, rotation.mat_from_euler(0.3, 0.2, 4.0))
    series, phi, dvel, _ = _navigate(truth, 120_000, fixed_position=True, decimation=1000)
    assert np.abs(dvel).max() < 1e-6  # m/s (round-off tilt ~1e-12 rad feeds g)
    assert np.abs(phi).max() < 1e-4 * ARCSEC
    assert np.array_equal(series.lla, np.broadcast_to([LAT, LON, HEIGHT], series.lla.shape))


def test_fixed_position_gyro_bias_follows_phi_equation():
    mat_nb = rotation.mat_from_euler(0.1, -0.05, 1.2)
    truth = tr.Stationary(LAT, LON, HEIGHT, mat_nb)
    bias = np.array([0.01, -0.02, 0.015]) * DPH
    series, phi, dvel, _ = _navigate(
        truth, 120_000, gyro_bias=bias, fixed_position=True, decimation=2000
    )
    # phi' = -omega_ie x phi - mat_nb b,  dv' = f_n x phi - 2 omega_ie x dv  (000 eqs. 9-10)
    aug = np.zeros((7, 7))
    aug[:6, :6] = _phi_model(LAT, HEIGHT, 6)
    aug[:3, 6] = -mat_nb @ bias
    closed = np.array([expm(aug * s)[:6, 6] for s in series.time(DT)])
    assert np.abs(phi - closed[:, :3]).max() < 1e-4 * np.abs(closed[:, :3]).max()
    assert np.abs(dvel - closed[:, 3:]).max() < 1e-4 * np.abs(closed[:, 3:]).max()
    # tilt grows linearly (no Schuler turn-back): within 3 % of -mat_nb b t at 10 min
    straight = -np.outer(series.time(DT), mat_nb @ bias)
    assert np.abs(phi[:, :2] - straight[:, :2]).max() < 0.03 * np.abs(straight[:, :2]).max()


def test_chunked_integration_is_bit_identical():
    truth = flight.aircraft_trajectory()
    dtheta, dv = tr.ideal_increments(truth, np.arange(3001) * DT)
    start = _start(truth)
    whole_end, whole = sd.integrate(start, dtheta, dv, DT, decimation=7)
    state, parts, lo = start, [], 0
    for size in (1, 6, 500, 333, 7, 1153, 1000):
        state, part = sd.integrate(
            state, dtheta[lo : lo + size], dv[lo : lo + size], DT, decimation=7
        )
        parts.append(part)
        lo += size
    joined = sd.NavSeries.concatenate(parts)
    assert lo == 3000 and state.count == whole_end.count == 3000
    for name in ("index", "quat_nb", "vel_n", "lla"):
        assert np.array_equal(getattr(joined, name), getattr(whole, name))
    assert np.array_equal(state.quat_nb, whole_end.quat_nb)
    assert np.array_equal(whole.index, np.arange(6, 3000, 7))


def test_state_and_series_helpers():
    euler = np.array([0.1, -0.2, 5.0])
    state = sd.NavState.from_attitude(euler, [1.0, 2.0, 3.0], [LAT, LON, HEIGHT])
    same = sd.NavState.from_attitude(rotation.mat_from_euler(*euler), [1, 2, 3], [LAT, LON, HEIGHT])
    np.testing.assert_allclose(state.quat_nb, same.quat_nb, atol=1e-15)
    np.testing.assert_allclose(state.mat_nb, rotation.mat_from_euler(*euler), atol=1e-15)
    _, series = sd.integrate(state, np.zeros((4, 3)), np.zeros((4, 3)), DT, decimation=2)
    assert series.euler().shape == (2, 3) and series.mat_nb().shape == (2, 3, 3)
    np.testing.assert_allclose(series.time(DT, t0=10.0), [10.0 + 2 * DT, 10.0 + 4 * DT])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"dt": 0.0}, "dt"),
        ({"decimation": 0}, "decimation"),
        ({"decimation": 1.5}, "decimation"),
        ({"dv": np.zeros((3, 3))}, "same shape"),
        ({"dtheta": np.zeros((4, 2))}, "shape"),
    ],
)
def test_bad_inputs_raise(kwargs, match):
    state = sd.NavState.from_attitude(np.eye(3), [0, 0, 0], [LAT, LON, HEIGHT])
    args = {"dtheta": np.zeros((4, 3)), "dv": np.zeros((4, 3)), "dt": DT} | kwargs
    with pytest.raises(ValueError, match=match):
        sd.integrate(state, args.pop("dtheta"), args.pop("dv"), args.pop("dt"), **args)
    with pytest.raises(ValueError, match="quat_nb"):
        sd.NavState([0, 0, 0, 0], [0, 0, 0], [0, 0, 0])


def test_zero_velocity_mode_integrates_the_plain_velocity_error():
    # 000 eqs. 9-10: phi' = -omega_ie x phi - mat_nb b, dv' = f_n x phi (no Coriolis: the
    # table's velocity is known to be zero)
    mat_nb = rotation.mat_from_euler(0.1, -0.05, 1.2)
    truth = tr.Stationary(LAT, LON, HEIGHT, mat_nb)
    bias = np.array([0.01, -0.02, 0.015]) * DPH
    dtheta, dv = tr.ideal_increments(truth, np.arange(120_001) * DT)
    start = sd.NavState.from_attitude(mat_nb, np.zeros(3), [LAT, LON, HEIGHT])
    _, series = sd.integrate(
        start, dtheta + bias * DT, dv, DT, fixed_position=True, zero_velocity=True, decimation=2000
    )
    aug = np.zeros((7, 7))
    aug[:6, :6] = _phi_model(LAT, HEIGHT, 6)
    aug[3:6, 3:6] = 0.0
    aug[:3, 6] = -mat_nb @ bias
    closed = np.array([expm(aug * s)[:6, 6] for s in series.time(DT)])
    phi = error_model.attitude_error(series.mat_nb(), mat_nb)
    assert np.abs(phi - closed[:, :3]).max() < 1e-4 * np.abs(closed[:, :3]).max()
    assert np.abs(series.vel_n - closed[:, 3:]).max() < 1e-4 * np.abs(closed[:, 3:]).max()
    with pytest.raises(ValueError, match="zero_velocity"):
        sd.integrate(start, dtheta[:5], dv[:5], DT, zero_velocity=True)
