"""The outlier gate of the loosely coupled filter's GNSS fixes (spec §6b), the same
bound screening a solution series for spikes before the filter (:func:`spikes`) and
the reference epochs of the outage scores (:func:`screen`).

A fix is a measurement vector: the antenna position (3 rows) or velocity (3 rows) of one
solution epoch. With its innovation ``y`` (measured minus predicted), rows ``H`` and
noise variances ``r`` (diagonal ``R``), the normalised innovation squared

    NIS = y^T S^-1 y,    S = H P H^T + R,

is chi-square with 3 degrees of freedom when the filter's model holds. The gate rejects
the fix when ``NIS > k^2 chi2_3^-1(p)``: the chi-square(3) quantile of the acceptance
probability ``p`` (the tight mode's ``gate_probability`` convention, there per scalar row
with 1 degree of freedom), the innovation covariance tested scaled by ``k^2``
(``sigma_scale``: 1 tests against the filter's own ``S``; a real MEMS filter on RTK
fixes predicts its innovations up to 28 times too small, spec §6b).

A gate alone rejects forever after a genuine jump of the solutions (a new datum, a wrong
fix the receiver keeps): after ``reinit_after`` consecutive rejected epochs the next fix
that fails re-initialises the states it measures from it (:func:`reinitialise`).
"""

import math

import numpy as np

from inins.core import earth, jit, stats

JUMP_SCALE = 1e6
"""A re-initialisation enters the smoother as process noise on the re-initialised states
of ``JUMP_SCALE`` times the squared innovation plus the noise variance (m^2, (m/s)^2):
the smoother's gain across the jump falls as its inverse (:func:`reinitialise`)."""


def bound(probability, sigma_scale, dof=3):
    """The gate's bound on the NIS: ``sigma_scale^2 chi2_dof^-1(probability)``; infinite
    (no gate) for ``probability`` 1.

    Parameters
    ----------
    probability : float
        Acceptance probability of a fix whose innovation has the covariance tested, in
        (0.5, 1].
    sigma_scale : float
        Scale ``k`` (>= 1) of the innovation's sigma tested against (1: the filter's).
    dof : int
        Rows of the fix.
    """
    if probability >= 1.0:
        return math.inf
    return float(sigma_scale**2 * stats.chi2_ppf(probability, dof))


@jit.njit(cache=True, error_model="numpy")
def nis(P, H, y, r):
    """``y^T (H P H^T + diag r)^-1 y`` of a fix: innovation ``y`` (p,), rows ``H`` (p, n),
    noise variances ``r`` (p,), state covariance ``P`` (n, n)."""
    S = H @ P @ H.T
    for i in range(y.shape[0]):
        S[i, i] += r[i]
    return float(y @ np.linalg.solve(S, y))


@jit.njit(cache=True, error_model="numpy")
def reinitialise(x, P, P_pred, H, y, r, states):
    """Re-initialise ``states`` (p,) from a fix whose rows ``H`` (p, n) are ``-I`` on them
    (the antenna position rows on ``POS``, the velocity rows on ``VEL``), in place.

    The update of an infinite prior on those states: with ``H_o`` the rows without their
    columns, ``y = -d + H_o e + v`` (``d`` their error, ``e`` the others'), so

        x_J -= y,   P_JJ = H_o P_oo H_o^T + R,   P_Jo = H_o P_oo

    and the other states keep their estimate and covariance: the solution's value with its
    sigma, correlated with the others only through the lever arm and the time offset.
    The smoother sees the jump as process noise at this epoch: ``P_pred`` (the logged
    prediction) gains ``JUMP_SCALE (y^2 + r)`` on the re-initialised diagonal, so the RTS
    gain across it vanishes and the jump is not smeared back.
    """
    p, n = H.shape
    Ho = H.copy()
    for i in range(p):
        Ho[:, states[i]] = 0.0
    A = Ho @ P  # (p, n): H_o P_o. on the other states' columns
    PJJ = A @ Ho.T
    for i in range(p):
        PJJ[i, i] += r[i]
    for i in range(p):
        a = states[i]
        x[a] -= y[i]
        for j in range(n):
            P[a, j] = A[i, j]
            P[j, a] = A[i, j]
    for i in range(p):
        for j in range(p):
            P[states[i], states[j]] = PJJ[i, j]
        P_pred[states[i], states[i]] += JUMP_SCALE * (y[i] * y[i] + r[i])


def screen(diff, var, limit):
    """Epochs whose difference fails the gate: ``sum(diff^2 / var) > limit`` per row.

    The reference epochs of the outage scores are tested so (:mod:`inins.ekf.scoring`):
    ``diff`` (m, 3) the reference antenna position minus the solution's (NED m), ``var``
    (m, 3) the sum of the reference's and the solution's variances per axis (m^2), the
    ``limit`` of :func:`bound`. Returns (m,) bool, True where it fails.
    """
    stat = np.sum(np.square(diff) / var, axis=1)
    return stat > limit


VEHICLE_ACCEL = 9.80665
"""Acceleration 1-sigma (m/s^2) a solution series is allowed between epochs by
:func:`spikes`: 1 g, more than a road vehicle does."""


def spikes(time, values, var, limit, order=2, accel=VEHICLE_ACCEL):
    """Epochs of a solution series inconsistent with the epochs on both sides of them.

    Each epoch is predicted from its two neighbours before it (a straight line, ``order``
    2: positions) or its one neighbour (``order`` 1: velocities), and again from those
    after it. A prediction's residual ``d`` (3,) has the variance per axis of the epochs'
    noise (``var``, the line's weights squared) plus the motion the line leaves out, an
    acceleration of 1-sigma ``accel``: ``(accel dt_1 dt_2 / 2)^2`` for the line
    (``dt`` from the epoch to the two it is predicted from), ``(accel dt)^2`` for one
    neighbour. The epoch fails a side when ``sum(d^2 / variance)`` exceeds ``limit``
    (:func:`bound`), and is a spike when it fails every side it has: a genuine jump of
    the series from some epoch on fails from before but not from after, and is kept (the
    filter's gate and re-initialisation deal with it). An epoch judged with a spike among
    its neighbours is judged again without it.

    Parameters
    ----------
    time : ndarray (m,)
        Epochs (s), increasing.
    values : ndarray (m, 3)
        Positions (ECEF m) or velocities (m/s); rows with a NaN are ignored (never spikes).
    var : ndarray (m, 3)
        Their variances per axis (m^2, (m/s)^2).
    limit : float
        Bound on the statistic (inf: no screening).
    order : {1, 2}
    accel : float
        m/s^2.

    Returns
    -------
    ndarray (m,) bool
        True for the spikes.
    """
    t = np.asarray(time, float)
    x, v = np.asarray(values, float), np.asarray(var, float)
    bad = np.zeros(t.size, bool)
    ok = np.flatnonzero(np.isfinite(x).all(axis=1) & np.isfinite(v).all(axis=1))
    if not math.isfinite(limit) or ok.size < order + 2:
        return bad
    bad[ok] = _fails(t[ok], x[ok], v[ok], limit, order, accel)
    for _ in range(3):  # the flagged, judged again against the unflagged only
        keep = ok[~bad[ok]]
        if keep.size < order + 2:
            break
        again = bad.copy()
        for k in np.flatnonzero(bad):
            idx = np.sort(np.append(keep, k))
            j = int(np.searchsorted(idx, k))
            lo, hi = max(j - order, 0), j + order + 1
            sub = idx[lo:hi]
            again[k] = _fails(t[sub], x[sub], v[sub], limit, order, accel)[j - lo]
        if np.array_equal(again, bad):
            break
        bad = again
    return bad


def _fails(t, x, v, limit, order, accel):
    """Whether each epoch fails every side it has (:func:`spikes`)."""
    m = t.size
    fails = np.ones(m, bool)
    sides = 0
    for side in (-1, 1):
        stat = _side(t, x, v, side, order, accel)
        have = np.isfinite(stat)
        fails &= ~have | (stat > limit)
        sides = sides + have
    return fails & (sides > 0)


def _side(t, x, v, side, order, accel):
    """The statistic of each epoch predicted from the ``order`` epochs on ``side`` (-1
    before, +1 after); NaN where there are not enough."""
    m = t.size
    out = np.full(m, np.nan)
    k = np.arange(m)
    a = k + side  # the nearer neighbour
    b = k + side * order  # the farther (order 2), or the same (order 1)
    have = (b >= 0) & (b < m)
    k, a, b = k[have], a[have], b[have]
    if order == 1:
        d = x[k] - x[a]
        var = v[k] + v[a] + (accel * (t[k] - t[a]))[:, None] ** 2
    else:
        w = (t[k] - t[a]) / (t[a] - t[b])  # x_k = x_a + w (x_a - x_b)
        d = x[k] - (x[a] + w[:, None] * (x[a] - x[b]))
        var = v[k] + ((1 + w) ** 2)[:, None] * v[a] + (w**2)[:, None] * v[b]
        var = var + (0.5 * accel * (t[k] - t[a]) * (t[k] - t[b]))[:, None] ** 2
    out[k] = np.sum(d**2 / var, axis=1)
    return out


def solution_spikes(time, lla, sigma_ned, vel_ned, sigma_vel, limit):
    """The position and velocity spikes (:func:`spikes`) of a solution series: positions
    in the NED axes of the first epoch (``lla`` (m, 3) rad, rad, m; ``sigma_ned`` (m, 3)
    m), velocities ``vel_ned`` (m, 3) m/s with ``sigma_vel`` (NaN rows: none); returns two
    (m,) bool arrays."""
    ecef = earth.ecef_from_llh(lla[:, 0], lla[:, 1], lla[:, 2])
    ned = (ecef - ecef[0]) @ earth.mat_en(lla[0, 0], lla[0, 1])
    pos = spikes(time, ned, np.square(sigma_ned), limit, order=2)
    vel = spikes(time, vel_ned, np.square(sigma_vel), limit, order=1)
    return pos, vel
