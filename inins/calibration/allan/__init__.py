"""Allan, modified and total deviation with confidence intervals, and the IEEE noise-term fit.

The modules: :mod:`~inins.calibration.allan.deviation` (the deviations of a record in
memory, their intervals, the noise identification), :mod:`~inins.calibration.allan.edf`
(the equivalent degrees of freedom), :mod:`~inins.calibration.allan.stream` (the
streaming accumulator and its kernels), :mod:`~inins.calibration.allan.fit` (the
five-term fit); their names are all here.

Data
----
A sensor at rest gives increments (angle rad, velocity m/s) every ``tau0`` s. Their
running sum is the *phase* ``x`` (rad or m/s; ``x_0 = 0``), the increments divided
by ``tau0`` are the *frequency* ``y`` (rate rad/s or specific force m/s^2): the
time-and-frequency names of NIST SP 1065 carry over, with ``x`` in angle instead of
time. At ``tau = m tau0`` (NIST SP 1065 eq. 14, 16; IEEE Std 952-1997 eq. C.2):

- overlapping Allan variance
  ``s2_A = sum_i (x_{i+2m} - 2 x_{i+m} + x_i)^2 / (2 tau^2 (N - 2m))``, i over all
  ``N - 2m`` starts (N + 1 phase points);
- modified Allan variance (SP 1065 eq. 15) averages the second difference over m
  consecutive starts before squaring;
- total variance (SP 1065 eq. 25) extends the phase by reflection at both ends
  (``x*_{1-j} = 2 x_1 - x_{1+j}``, ``x*_{N+j} = 2 x_N - x_{N-j}``) and takes the
  second difference at every interior point.

Streaming (:class:`AllanAccumulator`)
-------------------------------------
The overlapping Allan variance at m needs only the phase at its starts. Above
``offsets`` starts per tau it is evaluated on the phase sampled every ``2^l``
points (level l: ``m = M 2^l`` with ``offsets <= M < 2 offsets``): the second
differences at every ``2^l``-th start, ``offsets`` of them per m. With 16 offsets
the result differs from the fully overlapping estimate by under a quarter of its
1-sigma interval (white noise, tests); its interval is computed with Greenhall &
Riley's edf for M starts per m (their S), not the fully overlapping one. ``offsets=0`` gives the
fully overlapping estimate at every tau. The accumulator keeps per
level only the last ``4 offsets`` phase points and the ones it gathers for the next
kernel call (``batch_rows``), so a record of any length streams through it in
chunks: the work is about ``(log2(offsets) + 2) N`` and the memory independent of
N. Each sum is continued point by point, so the result does not depend on how the
record is cut into chunks.

Confidence intervals
--------------------
Each deviation comes with the chi-square interval ``s2 edf / chi2_{1-p/2}(edf) <=
sigma^2 <= s2 edf / chi2_{p/2}(edf)`` (SP 1065 eq. 45), the equivalent degrees of
freedom edf from Greenhall & Riley, "Uncertainty of stability variances based on
finite differences", PTTI 2003 (the algorithm of Stable32; their eqs. 7-13 and
Tables 1-3) for the Allan and modified variances, and SP 1065 Table 7 for the total
variance. Those edf assume **one power-law noise** ``S_y(f) ~ f^alpha`` at each tau.
alpha is identified per tau from the lag-1 autocorrelation of the tau-averaged rate
(Riley & Greenhall, "Power law noise identification using the lag 1
autocorrelation", 2004: difference the series d times until
``delta = r1 / (1 + r1) < 0.25`` (at most twice), then
``alpha = -round(2 delta) - 2 d``, clipped to [-4, 2]; needs 30 averages; with fewer
the alpha of the next shorter tau is kept). The edf takes alpha >= -2 (d = 2). For
inertial sensors: alpha = +2 quantization (white angle), 0 angle/velocity random
walk (white rate), -1 bias instability (flicker rate), -2 rate random walk. A curve
that mixes terms at a tau, or carries a periodic part (an RLG's dither), breaks the
single-noise assumption; the interval is then approximate.

Noise terms (IEEE Std 952-1997 Annex C, Table C.1)
--------------------------------------------------
``s2_A(tau) = 3 Q^2 / tau^2 + N^2 / tau + (2 ln 2 / pi) B^2 + K^2 tau / 3 + R^2 tau^2 / 2``

Q quantization (rad or m/s), N angle/velocity random walk (rad/sqrt(s), m/s/sqrt(s)),
B bias instability (rad/s, m/s^2; the flat part of the deviation is
``sqrt(2 ln 2 / pi) B = 0.664 B``), K rate random walk (rad/s/sqrt(s)), R rate ramp
(rad/s^2). :func:`fit_terms` fits the five squared coefficients by non-negative
weighted least squares in the variance, weights ``edf / (2 s2_model^2)`` (the
variance of a chi-square estimate), iterated on the model, each coefficient bounded by
what the curve allows (its variance alone within the curve's upper limit at every tau).
Each term is reported with the tau range where it carries at least half the model
variance, and its interval from the covariance of the fit with the estimates'
correlation across tau (:mod:`inins.calibration.allan.covariance`); the model check is
the fit's chi-square with that covariance (see :func:`fit_terms`).
"""

from inins.calibration.allan.deviation import (
    ID_MIN_POINTS,
    KINDS,
    ONE_SIGMA,
    WILSON_HILFERTY_DOF,
    Deviation,
    adev_phase,
    autocorr_alpha,
    chi2_interval,
    deviations,
    lag1,
    mdev_phase,
    oadev_phase,
    phase_of,
    tau_grid,
    totdev_phase,
)
from inins.calibration.allan.edf import J_MAX, edf_for, edf_greenhall, edf_totdev
from inins.calibration.allan.fit import (
    BIAS_FACTOR,
    EDF_CAP,
    MIN_DOMINANT_EDF,
    MODEL_P,
    SLOPES,
    TERMS,
    Fit,
    Term,
    basis,
    fit_terms,
    nnls,
    simulate_increments,
)
from inins.calibration.allan.stream import DIFFERENCE_ROWS, AllanAccumulator, _level

__all__ = [
    "BIAS_FACTOR",
    "DIFFERENCE_ROWS",
    "EDF_CAP",
    "ID_MIN_POINTS",
    "J_MAX",
    "KINDS",
    "MIN_DOMINANT_EDF",
    "MODEL_P",
    "ONE_SIGMA",
    "SLOPES",
    "TERMS",
    "WILSON_HILFERTY_DOF",
    "AllanAccumulator",
    "Deviation",
    "Fit",
    "Term",
    "_level",
    "adev_phase",
    "autocorr_alpha",
    "basis",
    "chi2_interval",
    "deviations",
    "edf_for",
    "edf_greenhall",
    "edf_totdev",
    "fit_terms",
    "lag1",
    "mdev_phase",
    "nnls",
    "oadev_phase",
    "phase_of",
    "simulate_increments",
    "tau_grid",
    "totdev_phase",
]
