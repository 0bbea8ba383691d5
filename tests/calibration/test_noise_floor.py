"""The 1-sigma of every estimator is honest, and the uncertainty budget covers the error
(issue 7): a 50-seed Monte Carlo of 000's no-disturbance sequence with realistic RLG noise,
tactical-size biases (1 and -0.7 deg/h, so the gyrocompass heading error is 4.4 deg) and
two systematic errors the budget states (100 ug accelerometer biases, a 0.1 deg/h
vertical gyro bias taken as zero), each 0.3-0.4 of the random 1-sigma.

Cost: 50 runs at 10 Hz with T = 300 s (the noise figures are densities, so the rate does
not change the 1-sigma; the strapdown discretisation at 10 Hz, ~1e-5 deg/h, is 1e-2 of
it), about a tenth of the former 200 runs at 50 Hz with T = 600 s.

Statistics: with n = 50 seeds the sample standard deviation s of a normal error with
standard deviation sigma has (n - 1) s^2 / sigma^2 ~ chi^2(n - 1); the two-sided 99.9 %
interval of s / sigma is [0.67, 1.37]. Each estimator's ratio must fall inside it (about
ten ratios are tested, so a false alarm is < 1 %). The mean error must be within
4 sigma / sqrt(n) of the systematic part the linear model predicts. Coverage: the chosen
estimate's error within 3 u (u: random and systematic terms in quadrature) in at least
99 % of the 50 runs, i.e. in all of them.
"""

import functools

import numpy as np
import pytest
from scipy import stats

from inins.calibration import bias
from inins.commands import calibrate_bias_report
from inins.commands._table import load_record
from inins.core.units import DEG_RTH
from inins.scenario.calibrate_bias import CalibrateBiasScenario
from inins.scenario.si.calibrate_bias import method_settings
from tests.helpers import shipped

SEEDS = 50
ARW_DEG_RTH = 0.001
MOTION = [
    {"kind": "hold", "duration_s": 120, "label": "align"},
    {"kind": "hold", "duration_s": 300, "label": "0deg"},
    {"kind": "rotate", "axis": "yaw", "angle_deg": 180, "rate_dps": 10},
    {"kind": "hold", "duration_s": 300, "label": "180deg"},
    {"kind": "rotate", "axis": "yaw", "angle_deg": -180, "rate_dps": 10},
    {"kind": "hold", "duration_s": 30, "label": "0deg-return"},
]


@functools.cache
def model():
    return shipped(
        CalibrateBiasScenario,
        "paper000/case1-no-disturbance.yaml",
        **{
            "alignment.duration_s": 110,
            "simulate.motion": MOTION,
            "simulate.imu.sample_rate_hz": 10,
            "simulate.imu.gyro.bias_dph": [1.0, -0.7, 0.1],
            "simulate.imu.gyro.arw_deg_rth": ARW_DEG_RTH,
            "simulate.imu.gyro.pulse_weight_arcsec": 0.1,
            "simulate.imu.accel": {
                "bias_ug": [100.0, -100.0, 0.0],
                "vrw_ug_rthz": 5.0,
                "pulse_weight_ug_s": 10.0,
            },
            "uncertainty.accel_bias_ug": 100.0,
            "uncertainty.gyro_bias_z_dph": 0.1,
        },
    )


@pytest.fixture(scope="module")
def monte_carlo():
    m = model()
    runs = []
    for seed in range(SEEDS):
        record, sensor = load_record(m.data, m.simulate, seed)
        outcome = bias.calibrate_bias(record, method_settings(m, sensor))
        runs.append(outcome)
    return runs


def named(outcome):
    return {
        k: v for k, v in calibrate_bias_report.result_names(outcome).items() if v[0] is not None
    }


def test_sample_scatter_matches_the_reported_sigma(monte_carlo):
    lo, hi = np.sqrt(stats.chi2.ppf([0.0005, 0.9995], SEEDS - 1) / (SEEDS - 1))
    names = named(monte_carlo[0])
    sigmas = {k: v[1] for k, v in names.items()}
    truth = monte_carlo[0].truth.bias
    for name, sigma in sigmas.items():
        sample = np.array([named(o)[name][0] for o in monte_carlo])
        ratio = sample.std(ddof=1) / sigma
        assert lo < ratio < hi, (name, ratio, lo, hi)
        axis = "xyz".index(name.split("_")[1])
        predicted = (
            np.mean([o.truth.predicted[_estimator(name)][_row(o, axis)] for o in monte_carlo])
            if _estimator(name)
            else None
        )
        if predicted is not None:  # the mean error is the linear model's systematic part
            mean_err = sample.mean() - truth[axis]
            assert abs(mean_err - predicted) < 4 * sigma / np.sqrt(SEEDS), (name, mean_err)


def _estimator(name):
    parts = name.split("_")
    if len(parts) == 2:  # the chosen beta_<axis>: from eq. 44 / eq. 38 here
        return "eq44"
    # eq. 45 after gyrocompassing carries the whole heading error (~beta_E): the linear
    # model predicts it to ~6 % at 4.4 deg, too coarse for the mean test; not a chosen one
    return parts[2] if parts[2] in ("attitude", "eq44") else None


def _row(outcome, axis):
    return outcome.geometry.horizontal.index(axis)


def test_sigma_is_near_the_white_noise_bound(monte_carlo):
    outcome = monte_carlo[0]
    bound = ARW_DEG_RTH * DEG_RTH / np.sqrt(sum(outcome.seq.hold_times))
    for name, (_, sigma) in named(outcome).items():
        if name.endswith("eq45"):
            # eq. 45 also carries the gyrocompass heading noise, ARW / sqrt(110 s) through
            # omega_N: it is not a white-noise average of the holds alone
            continue
        assert 1.0 / 2.0 < sigma / bound < 2.0, (name, sigma / bound)


def test_three_u_covers_the_chosen_error_in_every_run(monte_carlo):
    budgets = calibrate_bias_report.chosen_budget(monte_carlo[0])
    assert budgets[0]["gyro_bias_z"] > 0.25 * budgets[0]["random"]  # a real systematic part
    assert budgets[1]["accel_bias"] > 0.25 * budgets[1]["random"]
    inside = []
    for outcome in monte_carlo:
        u = calibrate_bias_report.chosen_budget(outcome)
        for axis in (0, 1):
            err = outcome.chosen[axis][0] - outcome.truth.bias[axis]
            inside.append(abs(err) < 3 * u[axis]["total"])
    assert np.mean(inside) >= 0.99, np.mean(inside)
    assert all(o.choice.east_formula == "eq44" for o in monte_carlo)  # no false mount
