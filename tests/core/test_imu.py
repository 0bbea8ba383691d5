"""Sensor error model: closed forms, noise statistics, quantization, chunking, validation.

Statistical tests use fixed seeds and bounds of five standard errors (SE), with
the SE written next to each assertion; a correct model fails one with
probability ~1e-6.
"""

import dataclasses
import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.signal import lfilter

from inins.core import imu, pulses
from inins.core.units import DEG_RTH, DPH, UG, UG_RTHZ

DT = 1e-3


def _zeros(n):
    return np.zeros((n, 3)), np.zeros((n, 3))


def _full_errors():
    """Every term non-zero, magnitudes exaggerated so that each one shows."""
    return imu.SensorErrors(
        gyro_bias=[1e-4, -2e-4, 3e-4],
        gyro_scale=[1e-3, -2e-3, 3e-3],
        gyro_misalignment=[1e-3, -2e-3, 3e-3, -4e-3, 5e-3, -6e-3],
        accel_bias=[1e-3, -2e-3, 3e-3],
        accel_scale=[-1e-3, 2e-3, -3e-3],
        accel_misalignment=[1e-3, -2e-3, 3e-3],
        gyro_arw=[1e-4, 2e-4, 3e-4],
        accel_vrw=[1e-3, 2e-3, 3e-3],
        gyro_bias_instability=[1e-4, 2e-4, 3e-4],
        gyro_bias_corr_time_s=[1.0, 2.0, np.inf],
        accel_bias_instability=[1e-3, 2e-3, 3e-3],
        accel_bias_corr_time_s=[3.0, 4.0, 5.0],
        gyro_temp_sensitivity=[1e-5, -2e-5, 3e-5],
        accel_temp_sensitivity=10 * UG,
        gyro_pulse_weight=1e-6,
        accel_pulse_weight=[1e-5, 2e-5, 3e-5],
    )


def _motion(n, seed=0):
    r = np.random.default_rng(seed)
    t = np.arange(n) * DT
    dtheta = np.stack([0.3 * np.sin(2 * t), 0.1 + 0.0 * t, -0.2 * np.cos(t)], -1) * DT
    dv = (np.array([0.5, -0.3, -9.8]) + 0.1 * r.standard_normal((n, 3))) * DT
    return dtheta, dv


# --- the error model's matrices and deterministic terms -----------------------------------


def test_matrices_layout():
    e = _full_errors()
    bxy, bxz, byx, byz, bzx, bzy = e.gyro_misalignment
    sx, sy, sz = e.gyro_scale
    np.testing.assert_array_equal(
        e.gyro_matrix(), [[1 + sx, bxy, bxz], [byx, 1 + sy, byz], [bzx, bzy, 1 + sz]]
    )
    ayx, azx, azy = e.accel_misalignment
    sx, sy, sz = e.accel_scale
    np.testing.assert_array_equal(
        e.accel_matrix(), [[1 + sx, 0, 0], [ayx, 1 + sy, 0], [azx, azy, 1 + sz]]
    )
    np.testing.assert_array_equal(imu.SensorErrors.none().gyro_matrix(), np.eye(3))


def test_scale_factor_closed_form():
    e = imu.SensorErrors(gyro_scale=[1e-4, -2e-4, 3e-4], accel_scale=[-5e-5, 6e-5, 7e-5])
    dtheta, dv = _motion(1000)
    g, a, _, truth = imu.apply_errors(dtheta, dv, DT, e, np.random.default_rng(0))
    np.testing.assert_allclose(g, (1 + e.gyro_scale) * dtheta, rtol=1e-15, atol=0)
    np.testing.assert_allclose(a, (1 + e.accel_scale) * dv, rtol=1e-15, atol=0)
    assert not truth.gyro.any() and not truth.accel.any()


@pytest.mark.parametrize("index", range(6))
def test_gyro_misalignment_axis_and_sign(index):
    # beta_ij: gyro i tilted toward axis j measures w_i + beta_ij w_j
    i, j = [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)][index]
    beta = np.zeros(6)
    beta[index] = 2e-3
    dtheta = np.zeros((5, 3))
    dtheta[:, j] = 0.01  # pure rate about axis j
    g, _, _, _ = imu.apply_errors(
        dtheta, dtheta, DT, imu.SensorErrors(gyro_misalignment=beta), np.random.default_rng(0)
    )
    expected = np.zeros((5, 3))
    expected[:, j] = 0.01
    expected[:, i] = 2e-3 * 0.01
    np.testing.assert_allclose(g, expected, rtol=1e-15, atol=0)


@pytest.mark.parametrize("index", range(3))
def test_accel_misalignment_axis_and_sign(index):
    i, j = [(1, 0), (2, 0), (2, 1)][index]
    alpha = np.zeros(3)
    alpha[index] = -3e-3
    e = imu.SensorErrors(accel_misalignment=alpha)
    for axis in range(3):
        dv = np.zeros((4, 3))
        dv[:, axis] = 0.02
        _, a, _, _ = imu.apply_errors(dv, dv, DT, e, np.random.default_rng(0))
        expected = dv.copy()
        if axis == j:
            expected[:, i] = -3e-3 * 0.02
        # the x accelerometer defines body x: no cross-axis term ever reaches it
        np.testing.assert_allclose(a, expected, rtol=1e-15, atol=0)


def test_bias_temperature_and_extra_closed_form():
    n = 500
    e = imu.SensorErrors(
        gyro_bias=[1e-5, -2e-5, 3e-5],
        accel_bias=[4e-4, -5e-4, 6e-4],
        gyro_temp_sensitivity=[1e-6, 2e-6, -3e-6],
        accel_temp_sensitivity=10 * UG,
    )
    temp = np.linspace(-0.1, 0.1, n)
    extra_a = np.zeros((n, 3))
    extra_a[n // 2 :, 0] = 50 * UG  # a bias step after a table rotation, 000 Fig. 2
    dtheta, dv = _zeros(n)
    g, a, _, truth = imu.apply_errors(
        dtheta,
        dv,
        DT,
        e,
        np.random.default_rng(0),
        temperature_delta=temp,
        accel_bias_extra=extra_a,
    )
    bias_g = e.gyro_bias + e.gyro_temp_sensitivity * temp[:, None]
    bias_a = e.accel_bias + e.accel_temp_sensitivity * temp[:, None] + extra_a
    np.testing.assert_allclose(truth.gyro, bias_g, rtol=1e-15, atol=1e-20)
    np.testing.assert_allclose(truth.accel, bias_a, rtol=1e-15, atol=1e-20)
    np.testing.assert_allclose(g, bias_g * DT, rtol=1e-15, atol=1e-23)
    np.testing.assert_allclose(a, bias_a * DT, rtol=1e-15, atol=1e-23)


def test_no_random_term_draws_nothing():
    rng = np.random.default_rng(3)
    before = rng.bit_generator.state
    e = imu.SensorErrors(gyro_bias=1e-5, gyro_scale=1e-4, gyro_pulse_weight=1e-6)
    imu.apply_errors(*_motion(100), DT, e, rng)
    assert rng.bit_generator.state == before


# --- white noise -------------------------------------------------------------------------


def _white_noise(n, arw, vrw, seed):
    e = imu.SensorErrors(gyro_arw=arw, accel_vrw=vrw)
    g, a, _, _ = imu.apply_errors(*_zeros(n), DT, e, np.random.default_rng(seed))
    return g, a


def test_white_noise_per_sample_std():
    n, arw, vrw = 400_000, 0.005 * DEG_RTH, 50 * UG_RTHZ
    g, a = _white_noise(n, arw, vrw, seed=11)
    for noise, density in ((g, arw), (a, vrw)):
        sigma = density * np.sqrt(DT)
        se = 1.0 / np.sqrt(2 * noise.size)  # relative SE of a sample std
        assert abs(noise.std() / sigma - 1.0) < 5 * se  # 5 SE = 0.32 %
        assert np.all(np.abs(noise.mean(axis=0)) < 5 * sigma / np.sqrt(n))
    corr = np.corrcoef(np.hstack([g, a]).T) - np.eye(6)
    assert np.max(np.abs(corr)) < 5 / np.sqrt(n)  # 5 SE of a null correlation


def test_angle_random_walk_growth_and_allan_slope():
    n, arw = 1_200_000, 0.005 * DEG_RTH
    g, _ = _white_noise(n, arw, 0.0, seed=12)
    lengths = np.array([1, 10, 100, 1000])
    std_walk, adev = [], []
    for m in lengths:
        blocks = g.reshape(n // m, m, 3).sum(axis=1)  # integrated angle over t = m dt
        count = blocks.size
        # random walk: std of the angle integrated over t is arw sqrt(t); SE of var sqrt(2/N)
        ratio = blocks.var() / (arw**2 * m * DT)
        assert abs(ratio - 1.0) < 5 * np.sqrt(2.0 / count)
        std_walk.append(np.sqrt(blocks.var()))
        # non-overlapping Allan variance arw^2 / tau; differences are MA(1) with
        # correlation -1/2, so the relative SE of the estimate is sqrt(3 / (K - 1))
        avar = 0.5 * np.mean(np.diff(blocks / (m * DT), axis=0) ** 2)
        assert abs(avar / (arw**2 / (m * DT)) - 1.0) < 5 * np.sqrt(3.0 / (count - 3))
        adev.append(np.sqrt(avar))
    t = lengths * DT
    # over three decades the slopes carry ~0.002 SE from the 1000-sample point
    assert abs(np.polyfit(np.log(t), np.log(std_walk), 1)[0] - 0.5) < 0.01
    assert abs(np.polyfit(np.log(t), np.log(adev), 1)[0] + 0.5) < 0.01


# --- Gauss-Markov bias -------------------------------------------------------------------


def test_gauss_markov_variance_and_autocorrelation():
    n, dt, tau = 1_000_000, 0.01, 0.5
    sigma_g, sigma_a = np.array([1e-4, 2e-4, 3e-4]), np.array([1e-3, 2e-3, 3e-3])
    e = imu.SensorErrors(
        gyro_bias_instability=sigma_g,
        gyro_bias_corr_time_s=tau,
        accel_bias_instability=sigma_a,
        accel_bias_corr_time_s=tau,
    )
    g, _, _, truth = imu.apply_errors(*_zeros(n), dt, e, np.random.default_rng(21))
    np.testing.assert_allclose(g, truth.gyro * dt, rtol=1e-15, atol=0)
    x = np.hstack([truth.gyro / sigma_g, truth.accel / sigma_a])  # unit sigma, 6 axes
    rho, lag = np.exp(-dt / tau), round(tau / dt)
    # truth is the trapezoid mean (c_k + c_k+1) / 2 of the exact AR(1) samples c_k:
    var_th = (1 + rho) / 2
    cov_th = rho**lag * (2 + rho + 1 / rho) / 4  # ~ exp(-1) sigma^2 at lag tau
    # SEs per axis (Bartlett) for an AR(1): var (2/n)(1+rho^2)/(1-rho^2); the lag-L
    # autocovariance adds rho^2L terms; pooled over 6 independent axes
    r2 = (1 + rho**2) / (1 - rho**2)
    se_var = np.sqrt(2 * r2 / n / 6)
    se_cov = np.sqrt((r2 * (1 + rho ** (2 * lag)) + 2 * lag * rho ** (2 * lag)) / n / 6)
    se_mean = np.sqrt((1 + rho) / (1 - rho) / n)
    assert np.all(np.abs(x.mean(axis=0)) < 5 * se_mean)
    assert abs(np.mean(x**2) - var_th) < 5 * se_var  # 5 SE = 0.020
    assert abs(np.mean(x[:-lag] * x[lag:]) - cov_th) < 5 * se_cov  # 5 SE = 0.017
    assert abs(cov_th - np.exp(-1)) < 1e-3


def test_gauss_markov_start_is_stationary():
    sigma = np.array([1e-4, 2e-4, 3e-4])
    e = imu.SensorErrors(gyro_bias_instability=sigma, gyro_bias_corr_time_s=100.0)
    rng = np.random.default_rng(5)
    starts = np.array([imu.ImuState.stationary(e, rng).gyro_gm for _ in range(20_000)])
    assert abs(np.mean((starts / sigma) ** 2) - 1.0) < 5 * np.sqrt(2 / starts.size)
    assert not imu.ImuState.stationary(e, rng).accel_gm.any()


def test_infinite_correlation_time_is_random_constant():
    e = imu.SensorErrors(accel_bias_instability=1e-3, accel_bias_corr_time_s=np.inf)
    _, _, state, truth = imu.apply_errors(*_zeros(1000), DT, e, np.random.default_rng(8))
    assert np.all(truth.accel == truth.accel[0]) and np.all(truth.accel[0] != 0)
    np.testing.assert_array_equal(state.accel_gm, truth.accel[0])


# --- quantization and pulse counts -------------------------------------------------------


def test_quantization_invariants():
    n, pulse_g, pulse_a = 200_000, 1.5e-6, 1e-5
    base = imu.SensorErrors(gyro_arw=1e-4, accel_vrw=1e-3, gyro_scale=1e-3)
    quant = imu.SensorErrors(
        gyro_arw=1e-4,
        accel_vrw=1e-3,
        gyro_scale=1e-3,
        gyro_pulse_weight=pulse_g,
        accel_pulse_weight=pulse_a,
    )
    dtheta, dv = _motion(n, seed=4)
    g0, a0, _, _ = imu.apply_errors(dtheta, dv, DT, base, np.random.default_rng(9))
    g1, a1, state, _ = imu.apply_errors(dtheta, dv, DT, quant, np.random.default_rng(9))
    for y, out, pulse, resid in (
        (g0, g1, pulse_g, state.gyro_residual),
        (a0, a1, pulse_a, state.accel_residual),
    ):
        counts = out / pulse
        assert np.max(np.abs(counts - np.rint(counts))) < 1e-9
        # y - out (within a pulse) is computed almost exactly, unlike cumsum(y) - cumsum(out)
        gap = np.cumsum(y - out, axis=0)
        assert np.max(np.abs(gap)) <= 0.5 * pulse * (1 + 1e-6)  # never a whole pulse
        np.testing.assert_allclose(gap[-1], resid, rtol=0, atol=1e-9 * pulse)
        # mean rate over the record is preserved to half a pulse over the record
        assert np.all(np.abs(out.mean(axis=0) - y.mean(axis=0)) <= 0.5 * pulse / n * 1.001)
        assert np.max(np.abs(out - y)) > 0.4 * pulse  # quantization did act


@settings(max_examples=40, deadline=None)
@given(st.floats(1e-7, 1e-3), st.floats(-1e-2, 1e-2), st.integers(0, 2**31))
def test_quantization_remainder_bounded(pulse, rate, seed):
    e = imu.SensorErrors(gyro_arw=1e-3, gyro_pulse_weight=pulse)
    dtheta = np.full((300, 3), rate * DT)
    g, _, state, _ = imu.apply_errors(dtheta, dtheta, DT, e, np.random.default_rng(seed))
    g0, _, _, _ = imu.apply_errors(
        dtheta, dtheta, DT, imu.SensorErrors(gyro_arw=1e-3), np.random.default_rng(seed)
    )
    gap = np.cumsum(g0 - g, axis=0)
    assert np.max(np.abs(gap)) <= 0.5 * pulse * (1 + 1e-6)
    assert np.all(np.abs(state.gyro_residual) <= 0.5 * pulse * (1 + 1e-9))


def test_counts_round_trip_is_exact():
    pulse = np.array([1e-6, 1.5e-6, 2e-6])
    e = imu.SensorErrors(gyro_arw=1e-4, gyro_pulse_weight=pulse)
    g, _, _, _ = imu.apply_errors(*_motion(5000), DT, e, np.random.default_rng(1))
    counts = pulses.counts_from_increments(g, pulse)
    assert counts.dtype == np.int32
    np.testing.assert_array_equal(pulses.increments_from_counts(counts, pulse), g)


def test_counts_validation():
    with pytest.raises(ValueError, match="integer multiples"):
        pulses.counts_from_increments([0.5e-6, 1e-6, 0.0], 1e-6)
    with pytest.raises(ValueError, match="overflow"):
        pulses.counts_from_increments([1.0, 0.0, 0.0], 1e-10)
    with pytest.raises(ValueError, match="pulse_weight"):
        pulses.counts_from_increments([0.0, 0.0, 0.0], 0.0)
    with pytest.raises(ValueError, match="integer array"):
        pulses.increments_from_counts(np.array([1.0, 2.0, 3.0]), 1e-6)


# --- reproducibility and chunking --------------------------------------------------------


def _reference(dtheta, dv, dt, e, rng, temp):
    """Vectorised numpy model with the documented draw order (no quantization)."""
    n = len(dtheta)
    sigma = np.concatenate([e.gyro_bias_instability, e.accel_bias_instability])
    tau = np.concatenate([e.gyro_bias_corr_time_s, e.accel_bias_corr_time_s])
    c0 = np.zeros(6)
    c0[sigma > 0] = sigma[sigma > 0] * rng.standard_normal(np.count_nonzero(sigma))
    white = np.concatenate([e.gyro_arw, e.accel_vrw]) * np.sqrt(dt)
    rho = np.exp(-dt / tau)
    drive = sigma * np.sqrt(1 - rho**2)
    on_w, on_c = np.flatnonzero(white), np.flatnonzero(drive)
    z = rng.standard_normal((n, on_w.size + on_c.size))
    noise, innov = np.zeros((n, 6)), np.zeros((n, 6))
    noise[:, on_w] = z[:, : on_w.size] * white[on_w]
    innov[:, on_c] = z[:, on_w.size :] * drive[on_c]
    c = np.vstack([c0, np.zeros((n, 6))])
    for k in range(6):  # c_k+1 = rho c_k + innovation_k
        c[1:, k], _ = lfilter([1.0], [1.0, -rho[k]], innov[:, k], zi=[rho[k] * c0[k]])
    bias = np.concatenate([e.gyro_bias, e.accel_bias]) + 0.5 * (c[:-1] + c[1:])
    bias += np.concatenate([e.gyro_temp_sensitivity, e.accel_temp_sensitivity]) * temp[:, None]
    g = dtheta @ e.gyro_matrix().T + bias[:, :3] * dt + noise[:, :3]
    a = dv @ e.accel_matrix().T + bias[:, 3:] * dt + noise[:, 3:]
    return g, a, bias


def test_matches_numpy_reference_and_draw_order():
    n = 20_000
    e = dataclasses.replace(
        _full_errors(), gyro_arw=[1e-4, 0.0, 3e-4], gyro_pulse_weight=0.0, accel_pulse_weight=0.0
    )  # a skipped channel, no quantization
    dtheta, dv = _motion(n)
    temp = np.linspace(0, 1, n)
    rng, rng_ref = np.random.default_rng(77), np.random.default_rng(77)
    g, a, _, truth = imu.apply_errors(dtheta, dv, DT, e, rng, temperature_delta=temp)
    g_ref, a_ref, bias_ref = _reference(dtheta, dv, DT, e, rng_ref, temp)
    assert rng.bit_generator.state == rng_ref.bit_generator.state  # same number of draws
    # differences are the rounding of the two recursions (lfilter vs the kernel)
    np.testing.assert_allclose(truth.gyro, bias_ref[:, :3], rtol=0, atol=1e-16)
    np.testing.assert_allclose(truth.accel, bias_ref[:, 3:], rtol=0, atol=1e-15)
    np.testing.assert_allclose(g, g_ref, rtol=0, atol=1e-16)
    np.testing.assert_allclose(a, a_ref, rtol=0, atol=1e-16)


def test_chunked_equals_single_call_bit_for_bit():
    n = 30_000
    e = _full_errors()
    dtheta, dv = _motion(n)
    temp = np.linspace(-0.2, 0.3, n)
    extra_g = np.zeros((n, 3))
    extra_g[n // 3 :] = 1e-6
    extra_a = np.ones((n, 3)) * 1e-4
    kwargs = {"temperature_delta": temp, "gyro_bias_extra": extra_g, "accel_bias_extra": extra_a}
    rng_one = np.random.default_rng(2024)
    one = imu.apply_errors(dtheta, dv, DT, e, rng_one, **kwargs)

    rng = np.random.default_rng(2024)
    state, parts = None, []
    edges = [0, 0, 1, 2, 777, 777, 12_345, n]
    for lo, hi in itertools.pairwise(edges):
        chunk_kwargs = {key: value[lo:hi] for key, value in kwargs.items()}
        g, a, state, truth = imu.apply_errors(
            dtheta[lo:hi], dv[lo:hi], DT, e, rng, state, **chunk_kwargs
        )
        parts.append((g, a, truth.gyro, truth.accel))
    for k, whole in enumerate((one[0], one[1], one[3].gyro, one[3].accel)):
        np.testing.assert_array_equal(np.concatenate([p[k] for p in parts]), whole)
    for name in ("gyro_gm", "accel_gm", "gyro_residual", "accel_residual"):
        np.testing.assert_array_equal(getattr(state, name), getattr(one[2], name))
    assert rng.bit_generator.state == rng_one.bit_generator.state


def test_seed_reproducible_and_seeds_differ():
    e, (dtheta, dv) = _full_errors(), _motion(2000)
    g1, *_ = imu.apply_errors(dtheta, dv, DT, e, np.random.default_rng(5))
    g2, *_ = imu.apply_errors(dtheta, dv, DT, e, np.random.default_rng(5))
    g3, *_ = imu.apply_errors(dtheta, dv, DT, e, np.random.default_rng(6))
    np.testing.assert_array_equal(g1, g2)
    assert np.any(g1 != g3)


def test_empty_record():
    g, a, state, truth = imu.apply_errors(*_zeros(0), DT, _full_errors(), np.random.default_rng(0))
    assert g.shape == a.shape == truth.gyro.shape == truth[1].shape == (0, 3)
    assert np.any(state.gyro_gm != 0)  # the stationary start was drawn


# --- validation --------------------------------------------------------------------------


def test_sensor_errors_broadcast_readonly_and_equality():
    e = imu.SensorErrors(gyro_bias=0.01 * DPH)
    np.testing.assert_array_equal(e.gyro_bias, np.full(3, 0.01 * DPH))
    with pytest.raises(ValueError):
        e.gyro_bias[0] = 1.0
    assert e == imu.SensorErrors(gyro_bias=[0.01 * DPH] * 3)
    assert e != imu.SensorErrors.none()


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"gyro_bias": [1.0, 2.0]}, "gyro_bias"),
        ({"gyro_misalignment": 0.0}, "gyro_misalignment"),
        ({"accel_misalignment": np.zeros(6)}, "accel_misalignment"),
        ({"accel_bias": [0.0, np.nan, 0.0]}, "accel_bias"),
        ({"gyro_arw": -1e-6}, "gyro_arw"),
        ({"accel_vrw": np.inf}, "accel_vrw"),
        ({"gyro_scale": -1.0}, "gyro_scale"),
        ({"accel_pulse_weight": [0.0, -1e-5, 0.0]}, "accel_pulse_weight"),
        ({"gyro_bias_corr_time_s": -1.0}, "gyro_bias_corr_time_s"),
        ({"accel_bias_instability": 1e-4}, "accel_bias_corr_time_s"),  # tau missing
    ],
)
def test_sensor_errors_validation(kwargs, name):
    with pytest.raises(ValueError, match=name):
        imu.SensorErrors(**kwargs)


@pytest.mark.parametrize(
    ("args", "kwargs", "name"),
    [
        ((np.zeros((4, 2)), np.zeros((4, 3)), DT), {}, "dtheta"),
        ((np.zeros((4, 3)), np.zeros((5, 3)), DT), {}, "dv"),
        ((np.zeros((4, 3)), np.zeros((4, 3)), 0.0), {}, "dt"),
        ((np.zeros((4, 3)), np.zeros((4, 3)), np.nan), {}, "dt"),
        (
            (np.zeros((4, 3)), np.zeros((4, 3)), DT),
            {"temperature_delta": np.zeros(3)},
            "temperature_delta",
        ),
        (
            (np.zeros((4, 3)), np.zeros((4, 3)), DT),
            {"gyro_bias_extra": np.zeros(4)},
            "gyro_bias_extra",
        ),
    ],
)
def test_apply_errors_validation(args, kwargs, name):
    with pytest.raises(ValueError, match=name):
        imu.apply_errors(*args, imu.SensorErrors(), np.random.default_rng(0), **kwargs)


def test_apply_errors_type_checks():
    with pytest.raises(TypeError, match="rng"):
        imu.apply_errors(*_zeros(2), DT, imu.SensorErrors(), np.random.RandomState(0))
    with pytest.raises(TypeError, match="state"):
        imu.apply_errors(*_zeros(2), DT, imu.SensorErrors(), np.random.default_rng(0), {})
    with pytest.raises(ValueError, match="gyro_gm"):
        imu.ImuState(np.zeros(2), np.zeros(3), np.zeros(3), np.zeros(3))


def test_truth_every_gives_block_means_of_the_per_sample_truth():
    errors = imu.SensorErrors(
        gyro_bias=1e-6,
        gyro_bias_instability=1e-6,
        gyro_bias_corr_time_s=0.05,
        accel_bias=1e-3,
        accel_bias_instability=1e-4,
        accel_bias_corr_time_s=0.02,
    )
    ideal = np.zeros((600, 3))
    full = imu.apply_errors(ideal, ideal, 0.01, errors, np.random.default_rng(5))
    block = imu.apply_errors(ideal, ideal, 0.01, errors, np.random.default_rng(5), truth_every=20)
    np.testing.assert_array_equal(block[0], full[0])
    np.testing.assert_allclose(block[3].gyro, full[3].gyro.reshape(30, 20, 3).mean(1), rtol=1e-13)
    np.testing.assert_allclose(block[3].accel, full[3].accel.reshape(30, 20, 3).mean(1), rtol=1e-13)
    with pytest.raises(ValueError, match="truth_every"):
        imu.apply_errors(ideal, ideal, 0.01, errors, np.random.default_rng(5), truth_every=7)
