"""Covariance analysis: the Riccati kernel against the core Kalman functions, and
002's degree-of-observability result against the closed-form floor.

Floor. With ``Q = 0`` no measurement adds information along an unobservable
direction ``v``, so for every epoch ``P >= v (v^T P0^-1 v)^-1 v^T`` and the
1-sigma of state ``i`` can never fall below ``|v_i| / sqrt(v^T P0^-1 v)``; once
the rest is observed it converges to that floor. In normalised coordinates
(``S0^-1 P S0^-1``) ``S0^-1 v`` keeps eigenvalue exactly 1.
"""

import numpy as np
import pytest

from inins.core import kalman
from inins.core.units import DEG, DPH, MG
from inins.exceptions import InputError
from inins.observability import covariance, models, pwcs
from inins.observability import measurements as meas
from inins.observability.segments import make_segment

LAT = 37.0 * DEG
LOS = np.array([[0.0, 0.0, -1.0], [0.5, 0.3, -0.8], [-0.4, 0.6, -0.6], [0.2, -0.7, -0.5]])
LOS = LOS / np.linalg.norm(LOS, axis=1)[:, None]
VEL = meas.Measurement("velocity", 0.05)
BASELINE_Y = meas.Measurement("dd_phase", 0.005, baseline_b=(0.0, 1.5, 0.0), los_n=LOS)
ALIGN12 = models.MODELS["align12"]
# 002-like in-flight alignment priors: 0.5 m/s, 1 deg, 1 mg, 1 deg/h
SIGMA_0 = np.r_[[0.5] * 3, [1 * DEG] * 3, [1 * MG] * 3, [1 * DPH] * 3]


def _level_flight(heading, duration=300.0):
    vel = 150.0 * np.array([np.cos(heading), np.sin(heading), 0.0])
    return make_segment(duration, (LAT, 2.2, 3000.0), heading=heading, vel_n=vel)


def test_riccati_kernel_equals_the_core_kalman_steps():
    seg = _level_flight(0.3, 5.5)  # five 1-s steps and one of 0.5 s
    noise = models.ProcessNoise(arw=0.01 * DEG / 60, vrw=1e-4, gyro_bias_rw=1e-10)
    res = covariance.analyse(ALIGN12, [seg], [VEL, BASELINE_Y], SIGMA_0, noise=noise)
    np.testing.assert_allclose(res.time, [0, 1, 2, 3, 4, 5, 5.5], rtol=0, atol=1e-12)
    F = ALIGN12.system_matrices([seg])[0]
    Qc = ALIGN12.noise_densities([seg], noise)[0]
    H, R = meas.measurement_matrix(ALIGN12.layout, seg, [VEL, BASELINE_Y])
    P, x = np.diag(SIGMA_0**2), np.zeros(12)
    for k, step in enumerate([1.0] * 5 + [0.5]):
        Phi, Qd = kalman.discretize(F, Qc, step)
        x, P = kalman.predict(x, P, Phi, Qd)
        x, P, _, _ = kalman.update(x, P, np.zeros(len(H)), H, R)
        np.testing.assert_allclose(res.sigma[k + 1], np.sqrt(np.diag(P)), rtol=1e-9)
    assert res.segment_end.tolist() == [6]
    np.testing.assert_array_equal(res.sigma[0], SIGMA_0)


def test_002_pitch_and_x_accel_bias_do_not_separate_until_the_manoeuvre():
    segs = [_level_flight(0.0), _level_flight(90 * DEG)]
    res = covariance.analyse(ALIGN12, segs, [VEL, BASELINE_Y], SIGMA_0)
    v = pwcs.analyse(ALIGN12, segs[:1], [VEL, BASELINE_Y]).null_space[:, 0]
    floor = np.abs(v) / np.sqrt(np.sum(v**2 / SIGMA_0**2))
    end = res.segment_end[0]
    names = ALIGN12.names
    level = res.sigma[1 : end + 1]
    for name in ("phi_E", "ba_x", "bg_x", "bg_z"):  # never below the floor in level flight
        i = names.index(name)
        assert level[:, i].min() >= floor[i] * (1 - 1e-9), name
    # ... and pitch and ba_x sit on it after 300 s (measured: 1.0001, 1.00002)
    for name in ("phi_E", "ba_x"):
        i = names.index(name)
        assert res.sigma[end, i] / floor[i] == pytest.approx(1.0, abs=0.01), name
    ratio_level = res.sigma[end] / SIGMA_0
    assert ratio_level[names.index("ba_x")] > 0.998  # ba_x does not shrink (measured 0.9983)
    # pitch can only shrink to sigma_ba / g: 0.0573 of its 1 deg
    assert ratio_level[names.index("phi_E")] == pytest.approx(MG / 9.79 / DEG, rel=0.01)
    # roll and heading, seen by the baseline and velocity, do shrink (measured 0.018, 0.028)
    assert ratio_level[names.index("phi_N")] < 0.03 and ratio_level[names.index("phi_D")] < 0.04
    # after the turn everything separates (measured: phi_E 6.4e-4, ba_x 8.3e-3)
    assert res.sigma_ratio[names.index("phi_E")] < 1e-3
    assert res.sigma_ratio[names.index("ba_x")] < 0.01
    assert res.sigma_ratio.max() < 0.2  # bg_z is the slowest (measured 0.187)


def test_normalised_covariance_keeps_eigenvalue_one_along_the_unobservable_direction():
    segs = [_level_flight(0.0), _level_flight(90 * DEG)]
    one = covariance.analyse(ALIGN12, segs[:1], [VEL, BASELINE_Y], SIGMA_0)
    v = pwcs.analyse(ALIGN12, segs[:1], [VEL, BASELINE_Y]).null_space[:, 0]
    y = v / SIGMA_0
    assert one.eigenvalues[0, 0] == pytest.approx(1.0, abs=1e-7)  # 300 updates: measured 7.5e-9
    assert abs(one.eigenvectors[:, 0] @ y) / np.linalg.norm(y) == pytest.approx(1.0, abs=1e-9)
    assert one.eigenvalues[0, 1] < 0.31  # next: 0.30 (bg_z, not yet observed)
    assert one.directions[0].startswith("- 0.102·phi_E + ba_x")  # phi_E = -ba_x / g
    both = covariance.analyse(ALIGN12, segs, [VEL, BASELINE_Y], SIGMA_0)
    assert both.eigenvalues[0, 0] == pytest.approx(1.0, abs=1e-7)
    assert both.eigenvalues[1, 0] < 0.05  # measured 0.035


def test_covariance_input_errors():
    seg = _level_flight(0.0, 10.0)
    with pytest.raises(InputError, match="sigmas") as err:
        covariance.analyse(ALIGN12, [seg], [VEL], SIGMA_0[:5])
    assert err.value.key == "sigma_0"
    with pytest.raises(InputError, match="interval"):
        covariance.analyse(ALIGN12, [seg], [VEL], SIGMA_0, dt=0.0)
