"""Single-point positioning: weighted least squares per epoch, batched over epochs.

Pseudorange model (spec §6a): ``P = |R(omega_e tau) r_sat - r_rx| + b - c dt_sv
+ T + I + e`` with ``b = c dt_rx`` (m). Gauss-Newton from the Earth's centre
(or a given start) on all epochs at once: the normal equations of every epoch
are stacked, ``(n, 4, 4)``, and solved together, so the cost per iteration is a
few numpy calls whatever the number of epochs. Weights ``sin^2(el) / sigma^2``
(elevation-dependent variance ``sigma^2 / sin^2 el``).

Integrity: the weighted sum of squared residuals is tested against the
chi-square quantile with ``n - 4`` degrees of freedom. When it fails and six
or more satellites were used, the satellite with the largest normalised
residual (Baarda's w-test, ``w_i = v_i / sqrt(Q_vv,ii)``) is excluded, the
epoch solved again and tested again; the excluded PRN is reported. With five
satellites a fault is detectable but not identifiable (all w_i are equal):
the epoch is flagged. Fewer than four satellites: no fix (recorded, not an error).

Velocity and clock drift from range rates (or Doppler, ``rate = -lambda_L1 D``):
``rdot = s (A - e . v_rx) + d - c dt_sv_dot`` (see
:func:`inins.gnss.propagation.geometry`), linear least squares at the fixed position.
"""

import enum
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from inins.core import earth
from inins.core.stats import chi2_ppf
from inins.core.units import DEG
from inins.gnss import propagation
from inins.gnss.measurements import Signal

NEAR_EARTH_M = 6.0e6
"""A position estimate farther than this from the centre is near the surface:
elevation mask, weights and troposphere apply (not to the first iterations from the centre)."""


class FixStatus(enum.IntEnum):
    """Outcome of an epoch."""

    FIX = 0
    NO_FIX = 1
    """Fewer than four usable satellites: no solution (position NaN)."""
    FAULT_EXCLUDED = 2
    """Residual test failed, one satellite excluded, test passed after."""
    FAULT_DETECTED = 3
    """Residual test failed and no single exclusion passes: solution kept, flagged."""
    NOT_CONVERGED = 4


@dataclass(frozen=True)
class SppOptions:
    """Settings of :func:`solve`.

    Attributes
    ----------
    mask_rad : float, rad
        Elevation mask.
    sigma_zenith_m : float, m
        Pseudorange 1-sigma at zenith (UERE) for the weights and the test. The
        default 1.5 m is the user range error of broadcast orbits and clocks
        with P-code noise; on the ABPO day (iono-free residual RMS 1.3 m median)
        it flags only the 26 m errors of G01 just after acquisition. The sigma
        a source states per measurement is not used here: sources state it
        inconsistently (the PSINS tc file gives 3-5 cm, the noise of a
        carrier-smoothed code, not its error).
    elevation_weights : bool
        ``sigma / sin(el)`` if True, else ``sigma`` for every satellite.
    false_alarm : float
        Probability of the residual test failing on fault-free data.
    exclude_faults : bool
    troposphere : bool
        Saastamoinen standard-atmosphere model.
    klobuchar : tuple of two (4,) arrays or None
        (alpha, beta) for L1 rows; the ionosphere-free rows need none.
    max_iterations : int
    """

    mask_rad: float = 10.0 * DEG
    sigma_zenith_m: float = 1.5
    elevation_weights: bool = True
    false_alarm: float = 1e-3
    exclude_faults: bool = True
    troposphere: bool = True
    klobuchar: tuple | None = None
    max_iterations: int = 12


@dataclass(frozen=True)
class SppSolution:
    """Per-epoch solution (n epochs) and per-measurement diagnostics (m rows).

    Attributes
    ----------
    week, time : ndarray, shape (n,)
        As in the observations (receive time tag, GPS sow).
    pos : ndarray, shape (n, 3), m, ECEF (NaN without a fix)
    clock : ndarray, shape (n,), m, receiver clock bias ``c dt_rx``
    vel : ndarray, shape (n, 3), m/s, ECEF (NaN without range rates)
    drift : ndarray, shape (n,), m/s, ``c dt_rx_dot``
    status : ndarray of int8, shape (n,), :class:`FixStatus`
    n_used : ndarray of int64, shape (n,), satellites in the position solution
    pdop : ndarray, shape (n,)
    residual_rms : ndarray, shape (n,), m, unweighted RMS of the used residuals
    excluded_prn : ndarray of int64, shape (n,), 0 when none was excluded
    residual : ndarray, shape (m,), m, pseudorange residual (measured - model)
    used : ndarray of bool, shape (m,)
    elevation, azimuth : ndarray, shape (m,), rad
    """

    week: np.ndarray
    time: np.ndarray
    pos: np.ndarray
    clock: np.ndarray
    vel: np.ndarray
    drift: np.ndarray
    status: np.ndarray
    n_used: np.ndarray
    pdop: np.ndarray
    residual_rms: np.ndarray
    excluded_prn: np.ndarray
    residual: np.ndarray
    used: np.ndarray
    elevation: np.ndarray
    azimuth: np.ndarray


def padded_rows(start):
    """(n, k) row index of each epoch's measurements, -1 past its count."""
    counts = np.diff(start)
    k = max(int(counts.max(initial=0)), 1)
    col = np.arange(k)
    return np.where(col < counts[:, None], start[:-1, None] + col, -1)


def _model_terms(los, rx_pos, sow, signal, options):
    """Elevation, azimuth, troposphere and ionosphere (m) per padded row; ``rx_pos`` (n, 1, 3)."""
    el, az = propagation.elevation_azimuth(los, rx_pos)
    lla = earth.llh_from_ecef(rx_pos[:, 0, :])
    delay = np.zeros_like(el)
    if options.troposphere:
        delay += propagation.troposphere_saastamoinen(lla[:, 2:3], lla[:, 0:1], el)
    if options.klobuchar is not None:
        alpha, beta = options.klobuchar
        iono = propagation.ionosphere_klobuchar(
            sow[:, None], lla[:, 0:1], lla[:, 1:2], el, az, alpha, beta
        )
        delay += np.where(signal == Signal.L1, iono, 0.0)
    return el, az, delay


def _weights(el, near, use, options):
    sin_el = np.where(
        near[:, None] & options.elevation_weights, np.sin(np.clip(el, 1e-3, None)), 1.0
    )
    ok = use & (~near[:, None] | (el >= options.mask_rad))
    return np.where(ok, sin_el**2 / options.sigma_zenith_m**2, 0.0), ok


def _normal(h, w, v):
    hw = h * w[..., None]
    return np.einsum("nki,nkj->nij", hw, h), np.einsum("nki,nk->ni", hw, v)


@dataclass(frozen=True)
class _Padded:
    """Measurements of n epochs padded to k slots: (n, k[, 3]); ``use`` False in the padding."""

    sat_pos: np.ndarray
    pr: np.ndarray
    clk: np.ndarray
    signal: np.ndarray
    use: np.ndarray
    sow: np.ndarray

    def take(self, k, use=None):
        return _Padded(
            self.sat_pos[k],
            self.pr[k],
            self.clk[k],
            self.signal[k],
            self.use[k] if use is None else use,
            self.sow[k],
        )


class _Fit(NamedTuple):
    """State of the batch least squares: x (n, 4) [m, m, m, m]; per slot (n, k): residual v
    (m), weight w (1/m^2), ok (used), el, az (rad); design h (n, k, 4); done (n,)."""

    x: np.ndarray
    v: np.ndarray
    w: np.ndarray
    ok: np.ndarray
    el: np.ndarray
    az: np.ndarray
    h: np.ndarray
    done: np.ndarray

    def take(self, k):
        return _Fit(*(a[k] for a in self))

    def put(self, k, other):
        """A copy with the epochs ``k`` replaced by ``other``'s."""
        arrays = [a.copy() for a in self]
        for a, b in zip(arrays, other, strict=True):
            a[k] = b
        return _Fit(*arrays)


def _pad(epochs, rows):
    have = rows >= 0
    r = np.where(have, rows, 0)
    obs = epochs.obs
    pr = np.where(have, obs.pseudorange[r], np.nan)
    return _Padded(
        sat_pos=np.where(have[..., None], epochs.sat_pos[r], [2.0e7, 0.0, 0.0]),
        pr=pr,
        clk=np.where(have, epochs.sat_clock[r], 0.0),
        signal=np.where(have, obs.signal[r], Signal.IONO_FREE),
        use=have & np.isfinite(pr),
        sow=obs.time,
    )


def _linearize(x, m, options):
    """Residuals, weights, used slots, elevation, azimuth and design matrix at ``x`` (n, 4)."""
    rx = x[:, None, :3]
    rng, _, los, _ = propagation.geometry(m.sat_pos, np.zeros_like(m.sat_pos), rx)
    near = np.linalg.norm(x[:, :3], axis=1) > NEAR_EARTH_M
    el, az, delay = _model_terms(los, rx, m.sow, m.signal, options)
    delay = np.where(near[:, None], delay, 0.0)
    v = m.pr - (rng + x[:, 3:4] - m.clk + delay)
    w, ok = _weights(el, near, m.use, options)
    h = np.concatenate([-los, np.ones_like(rng)[..., None]], axis=-1)
    return v, w, ok, el, az, h, near


def _iterate(x, m, options):
    """Gauss-Newton on all epochs at once, from ``x`` (n, 4), on the padded measurements ``m``.

    The returned residuals are evaluated at the final ``x``.
    """
    done = np.zeros(len(x), bool)
    for _ in range(options.max_iterations):
        v, w, ok, _, _, h, near = _linearize(x, m, options)
        nmat, rhs = _normal(h, np.where(np.isfinite(v), w, 0.0), np.nan_to_num(v))
        enough = ok.sum(axis=1) >= 4
        nmat[~enough] = np.eye(4)
        rhs[~enough] = 0.0
        dx = np.linalg.solve(nmat, rhs[..., None])[..., 0]
        dx[done] = 0.0
        x = x + dx
        done |= (np.abs(dx).max(axis=1) < 1e-4) & near
        if done[enough].all():
            break
    v, w, ok, el, az, h, _ = _linearize(x, m, options)
    return _Fit(x, v, w, ok, el, az, h, done)


def _w_test(h, w, v, ok):
    """Normalised residuals ``v_i / sqrt(Q_vv,ii)`` with ``Q_vv = W^-1 - H N^-1 H^T``."""
    nmat, _ = _normal(h, w, v)
    ninv = np.linalg.inv(nmat)
    hq = np.einsum("nki,nij,nkj->nk", h, ninv, h)
    qvv = np.where(ok, 1.0 / np.where(w > 0, w, 1.0) - hq, np.inf)
    return np.where(ok & (qvv > 1e-12), np.abs(v) / np.sqrt(np.abs(qvv)), 0.0)


def _chi2_fail(w, v, ok, false_alarm):
    dof = ok.sum(axis=1) - 4
    chi2 = np.sum(np.where(ok, w * v**2, 0.0), axis=1)
    limit = chi2_ppf(1.0 - false_alarm, np.maximum(dof, 1))
    return (dof > 0) & (chi2 > limit)


def solve(epochs, options=SppOptions(), initial=None):
    """Single-point position, clock, velocity and drift for every epoch.

    Parameters
    ----------
    epochs : GnssEpochs
    options : SppOptions
    initial : ndarray, shape (n, 3) or (3,), m, optional
        Start of the iteration (the Earth's centre when None).

    Returns
    -------
    SppSolution
    """
    obs = epochs.obs
    n = obs.n_epochs
    rows = padded_rows(obs.start)
    padded = _pad(epochs, rows)
    x0 = np.zeros((n, 4))
    if initial is not None:
        x0[:, :3] = initial
    fit = _iterate(x0, padded, options)
    status = np.where(fit.done, FixStatus.FIX, FixStatus.NOT_CONVERGED).astype(np.int8)
    excluded = np.zeros(n, np.int64)
    fail = _chi2_fail(fit.w, fit.v, fit.ok, options.false_alarm)
    status[fail] = FixStatus.FAULT_DETECTED
    if options.exclude_faults and fail.any():
        fit, fixed, prn = _exclude(np.flatnonzero(fail), fit, padded, obs.prn, rows, options)
        status[fixed], excluded[fixed] = FixStatus.FAULT_EXCLUDED, prn
    no_fix = fit.ok.sum(axis=1) < 4
    fit = fit._replace(ok=fit.ok & ~no_fix[:, None])
    n_used = fit.ok.sum(axis=1)
    status[no_fix] = FixStatus.NO_FIX
    x = np.where(no_fix[:, None], np.nan, fit.x)
    rms = np.sqrt(np.sum(np.where(fit.ok, fit.v**2, 0.0), axis=1) / np.maximum(n_used, 1))
    vel, drift = _velocity(epochs, rows, x, fit.ok, fit.el, options)
    have = rows >= 0
    per_row = {}
    for name, value in (("residual", fit.v), ("elevation", fit.el), ("azimuth", fit.az)):
        per_row[name] = np.full(len(obs.prn), np.nan)
        per_row[name][rows[have]] = value[have]
    used = np.zeros(len(obs.prn), bool)
    used[rows[have]] = fit.ok[have]
    return SppSolution(
        week=obs.week,
        time=obs.time,
        pos=x[:, :3],
        clock=x[:, 3],
        vel=vel,
        drift=drift,
        status=status,
        n_used=n_used,
        pdop=np.where(no_fix, np.nan, _pdop(fit.h, fit.ok)),
        residual_rms=np.where(no_fix, np.nan, rms),
        excluded_prn=excluded,
        used=used,
        **per_row,
    )


def _exclude(failed, fit, padded, prn, rows, options):
    """Exclude the satellite with the largest w-statistic in failed epochs with >= 6 used.

    Returns the fit with the epochs that pass after the exclusion replaced, those
    epochs (int array) and the PRN excluded in each.
    """
    candidates = failed[fit.ok[failed].sum(axis=1) >= 6]
    if candidates.size == 0:
        return fit, candidates, np.zeros(0, np.int64)
    sub = fit.take(candidates)
    worst = np.argmax(_w_test(sub.h, sub.w, sub.v, sub.ok), axis=1)
    use = padded.use[candidates].copy()
    use[np.arange(len(candidates)), worst] = False
    again = _iterate(sub.x, padded.take(candidates, use), options)
    passed = ~_chi2_fail(again.w, again.v, again.ok, options.false_alarm) & again.done
    fixed = candidates[passed]
    return fit.put(fixed, again.take(passed)), fixed, prn[rows[fixed, worst[passed]]]


def _pdop(h, ok):
    """Position dilution of precision of the used, unweighted geometry."""
    nmat, _ = _normal(h, ok.astype(float), np.zeros(ok.shape))
    good = ok.sum(axis=1) >= 4
    nmat[~good] = np.eye(4)
    q = np.linalg.inv(nmat)
    return np.where(good, np.sqrt(np.trace(q[:, :3, :3], axis1=1, axis2=2)), np.nan)


def _velocity(epochs, rows, x, ok, el, options):
    """Receiver velocity and clock drift from range rates at the fixed position."""
    r = np.where(rows >= 0, rows, 0)
    rate = np.where(rows >= 0, epochs.obs.range_rate[r], np.nan)
    use = ok & np.isfinite(rate) & np.isfinite(x[:, :1])
    rx = np.nan_to_num(x[:, None, :3])
    _, geo, los, scale = propagation.geometry(epochs.sat_pos[r], epochs.sat_vel[r], rx)
    y = np.where(use, rate - geo + epochs.sat_drift[r], 0.0)
    h = np.concatenate([-scale[..., None] * los, np.ones_like(geo)[..., None]], axis=-1)
    sin_el = np.sin(np.clip(el, 1e-3, None)) if options.elevation_weights else 1.0
    nmat, rhs = _normal(h, np.where(use, sin_el**2, 0.0), y)
    good = use.sum(axis=1) >= 4
    nmat[~good] = np.eye(4)
    sol = np.linalg.solve(nmat, rhs[..., None])[..., 0]
    sol[~good] = np.nan
    return sol[:, :3], sol[:, 3]


@dataclass(frozen=True)
class Track:
    """Track of a solution: ``distance`` (n,) m cumulative horizontal+vertical path length
    along the fixes (no-fix epochs add nothing), ``speed`` (n,) m/s horizontal speed from
    the range-rate velocity, ``vel_n`` (n, 3) m/s NED velocity."""

    distance: np.ndarray
    speed: np.ndarray
    vel_n: np.ndarray


def track(solution):
    """Path length and speed profile of an SPP solution (for reports)."""
    pos = solution.pos
    fixed = np.flatnonzero(np.isfinite(pos[:, 0]))
    step = np.zeros(len(pos))
    step[fixed[1:]] = np.linalg.norm(np.diff(pos[fixed], axis=0), axis=1)
    lla = earth.llh_from_ecef(np.nan_to_num(pos))
    vel_n = np.einsum("nji,nj->ni", earth.mat_en(lla[:, 0], lla[:, 1]), solution.vel)
    return Track(distance=np.cumsum(step), speed=np.hypot(vel_n[:, 0], vel_n[:, 1]), vel_n=vel_n)


def errors_ned(solution, reference_pos_e):
    """Position error of each epoch against a known antenna position, NED at the reference.

    Parameters
    ----------
    solution : SppSolution
    reference_pos_e : array_like, shape (3,), m, ECEF

    Returns
    -------
    ndarray, shape (n, 3), m (NaN without a fix); its norm is the 3D error.
    """
    ref = np.asarray(reference_pos_e, float)
    lla = earth.llh_from_ecef(ref)
    return (solution.pos - ref) @ earth.mat_en(lla[0], lla[1])
