"""Issue 7 item 6: each systematic term of the uncertainty budget against a noise-free run
that injects only that error (within 20 %; measured: within 1 % for the deterministic
terms), and the bias-instability term against a Monte Carlo of the Gauss-Markov bias.

The budget states each error at its 1-sigma on every component and adds the components
in quadrature; the injected runs put the stated value on one component at a time, and
the root-sum-square of their effects is the budget term. The table turns at 10 deg/s: a
misalignment error integrates along the rotating axis, and what survives the two turns
is a few per cent of each turn's integral, so the weights are evaluated at the middle of
each output interval (the end point is 0.5 deg off at 10 Hz and gave +65 % on beta_yz).
"""

import functools
from dataclasses import replace

import numpy as np
import pytest
from scipy import stats

from inins.calibration import bias, budget
from inins.commands._table import load_record
from inins.core.units import ARCSEC, DPH, PPM, UG
from inins.scenario.calibrate_bias import CalibrateBiasScenario
from inins.scenario.si.calibrate_bias import method_settings
from tests.helpers import shipped

BETA = [0.01, -0.02, 0.0]
STATED = budget.StatedErrors(
    accel_bias=50 * UG,
    gyro_bias_z=0.01 * DPH,
    gyro_scale=np.full(3, 10 * PPM),
    gyro_misalignment=np.full(6, 5 * ARCSEC),
)
PAIRS = ("xy", "xz", "yx", "yz", "zx", "zy")


def calibrate(method="gyrocompass", seed=1, stated=STATED, rate=10, **updates):
    extra = {"alignment.heading_deg": 90.0} if method == "known" else {}
    model = shipped(
        CalibrateBiasScenario,
        "paper000/case1-no-disturbance.yaml",
        **{
            "simulate.imu.gyro.bias_dph": BETA,
            "simulate.imu.sample_rate_hz": rate,
            "alignment.method": method,
            **extra,
            **updates,
        },
    )
    record, sensor = load_record(model.data, model.simulate, seed)
    settings = replace(method_settings(model, sensor), stated=stated)
    return bias.calibrate_bias(record, settings)


def errors(outcome):
    return {k: outcome.estimates[k].value - outcome.truth.bias[:2] for k in ("eq44", "eq45")}


INJECTIONS = {
    "accel_bias": [{"simulate.imu.accel.bias_ug": v} for v in ([50.0, 0, 0], [0, 50.0, 0])],
    "gyro_bias_z": [{"simulate.imu.gyro.bias_dph": [*BETA[:2], 0.01]}],
    "gyro_scale": [
        {"simulate.imu.gyro.scale_ppm": [10.0 * (i == k) for i in range(3)]} for k in range(3)
    ],
    "misalignment": [{f"simulate.imu.gyro.misalignment_arcsec.{p}": 5.0} for p in PAIRS],
}


@functools.cache
def clean_run(method):
    return calibrate(method)


@pytest.mark.parametrize("method", ["gyrocompass", "known"])
@pytest.mark.parametrize("term", list(INJECTIONS))
def test_systematic_term_matches_the_injected_error(method, term):
    base = clean_run(method)
    clean = errors(base)
    effects = {k: [] for k in clean}
    for updates in INJECTIONS[term]:
        injected = errors(calibrate(method, **updates))
        for k in clean:
            effects[k].append(injected[k] - clean[k])
    for k in ("eq44", "eq45"):
        rss = np.sqrt(np.sum(np.square(effects[k]), axis=0))
        stated = base.budgets[k].terms[term]
        big = rss > 2e-5 * DPH  # terms below 2e-5 deg/h sit at the discretisation level
        assert np.any(big) or term == "gyro_bias_z", (k, rss / DPH)
        np.testing.assert_allclose(stated[big], rss[big], rtol=0.20, err_msg=f"{k} {term}")


def test_accel_bias_leaks_into_eq38_as_the_vertical_earth_rate():
    """Issue 7: ~ Omega_D nabla / g on eq. 38 after gyrocompassing (4.6e-4 deg/h for 50 ug
    at 37 deg)."""
    term = clean_run("gyrocompass").budgets["eq44"].terms["accel_bias"][1] / DPH
    omega_d = 15.041 * np.sin(np.radians(37.0))
    assert term == pytest.approx(omega_d * 50e-6, rel=0.05)


@pytest.mark.slow
def test_bias_instability_term_matches_a_monte_carlo():
    """40 seeds of a Gauss-Markov bias (0.01 deg/h, 600 s) alone, 10 Hz: the root mean
    square of the eq. 44 / eq. 38 error lies in the 99 % chi-square interval of the budget
    term for 40 degrees of freedom, [0.72, 1.29] (the 20 % of the issue needs ~170 seeds;
    the noise-free injections above carry that tolerance)."""
    seeds = 40
    stated = budget.StatedErrors(bias_instability=0.01 * DPH, corr_time=600.0)
    updates = {
        "simulate.imu.gyro.bias_instability_dph": 0.01,
        "simulate.imu.gyro.bias_corr_time_s": 600.0,
    }
    errs, term, z, chosen = [], None, [], []
    for seed in range(seeds):
        out = calibrate(seed=seed, stated=stated, rate=10, **updates)
        errs.append(out.estimates["eq44"].value - out.truth.bias[:2])
        term = out.budgets["eq44"].terms["bias_instability"]
        z.append(out.check.residual / out.check.sigma)
        chosen.append(out.choice.east_formula)
    ratio = np.sqrt(np.mean(np.square(errs), axis=0)) / term
    lo, hi = np.sqrt(stats.chi2.ppf([0.005, 0.995], seeds) / seeds)
    assert np.all((lo < ratio) & (ratio < hi)), (ratio, lo, hi)
    # the mount check's 1-sigma carries the wandering bias too: no false mount rotation,
    # and the residual scatters as its 1-sigma says (same chi-square interval)
    assert chosen == ["eq44"] * seeds
    z_ratio = np.sqrt(np.mean(np.square(z), axis=0))
    assert np.all((lo < z_ratio) & (z_ratio < hi)), (z_ratio, lo, hi)
