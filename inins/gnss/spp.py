"""Single-point positioning: weighted least squares per epoch, batched over epochs.

Pseudorange model (spec §6a): ``P = |R(omega_e tau) r_sat - r_rx| + b - c dt_sv
+ T + I + e`` with ``b = c dt_rx`` (m). Gauss-Newton from Bancroft's closed-form
solution of each epoch (:func:`bancroft`; the Earth's centre where it has none near the
Earth's surface, or a given start) on all epochs at once: the normal equations of every epoch
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

Several systems: one receiver clock ``b`` plus one inter-system bias per further
system present in the data (``P = ... + b + b_s`` on rows of system ``s``; the bias
takes the system time offsets, GLONASS-GPS, Galileo GGTO, BDT 14 s is already
removed, and the receiver's inter-system code biases). In an epoch the lowest
system present carries ``b`` alone (its bias column is left out), so an epoch
needs ``3 + (systems present)`` satellites. GLONASS channels share one bias: the
receiver's inter-frequency code biases (up to ~1 m between channels) stay in the
residuals. Per-system elevation masks and sigma scales: :class:`SppOptions`.
GPS-only data give exactly the four-unknown solution.

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
from inins.gnss import propagation, systems
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
        (alpha, beta) for L1 rows; the ionosphere-free rows need none. Other systems'
        band-1 rows take it scaled by ``(f_L1 / f)^2``.
    max_iterations : int
    system_mask_rad : tuple of (system index, rad) pairs
        Elevation mask of a system instead of ``mask_rad``.
    system_sigma_scale : tuple of (system index, factor) pairs
        Pseudorange sigma of a system's rows = factor * ``sigma_zenith_m`` (1 when absent).
    max_exclusions : int
        Satellites excluded one after another (largest w first) until the residual test
        passes; each exclusion keeps two rows of redundancy. 1 on clean sky (a station);
        several in a city, where more than one signal arrives reflected.
    snr_reference_dbhz : float or None, dB-Hz
        Carrier-to-noise weighting: a row's sigma is multiplied by
        ``max(1, 10^((ref - C/N0) / 20))`` (variance ``~ 10^(-C/N0 / 10)`` below the
        reference, the model of Kuusniemi et al. 2004); None: no weighting. Rows without
        C/N0 keep factor 1.
    """

    mask_rad: float = 10.0 * DEG
    sigma_zenith_m: float = 1.5
    elevation_weights: bool = True
    false_alarm: float = 1e-3
    exclude_faults: bool = True
    troposphere: bool = True
    klobuchar: tuple | None = None
    max_iterations: int = 12
    system_mask_rad: tuple = ()
    system_sigma_scale: tuple = ()
    max_exclusions: int = 1
    snr_reference_dbhz: float | None = None


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
    excluded_prn : ndarray of int64, shape (n,), 0 when none was excluded (the first one
        when several were)
    n_excluded : ndarray of int64, shape (n,), satellites excluded
    isb : ndarray, shape (n, j), m, inter-system bias of each system of ``isb_systems``
        (NaN in epochs where that system is absent or carries the clock)
    isb_systems : tuple of int, the system indices of the ``isb`` columns
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
    n_excluded: np.ndarray
    isb: np.ndarray
    isb_systems: tuple
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


BANCROFT_SURFACE_M = (6.25e6, 6.5e6)
"""Distances from the Earth's centre (m) within which a closed-form solution starts the
iteration (the surface, 6357-6378 km, from 120 km below to 120 km above); outside,
the iteration starts from the Earth's centre."""


def bancroft(sat_pos, rho, use):
    """Closed-form receiver position and clock of each epoch (Bancroft 1985).

    With ``a_i = (s_i, rho_i)`` and the Lorentz product ``<p, q> = p1 q1 + p2 q2 +
    p3 q3 - p4 q4``, every row gives ``<a_i, y> = <a_i, a_i> / 2 + L`` for ``y = (r, b)``,
    ``L = <y, y> / 2``: the weighted least-squares ``u = B+ 1``, ``v = B+ alpha`` give
    ``y = M (v + L u)`` and ``<u, u> L^2 / 2 + (<u, v> - 1) L + <v, v> / 2 = 0`` (two
    roots: the one whose ``|r|`` lies within :data:`BANCROFT_SURFACE_M` and that sees its
    satellites highest, the mean cosine of their zenith angles above zero). No Earth
    rotation, troposphere or ionosphere: a start for the Gauss-Newton iteration, tens
    of metres from the solution.

    Parameters
    ----------
    sat_pos : ndarray, shape (n, k, 3), m
    rho : ndarray, shape (n, k), m, pseudorange plus satellite clock ``P + c dt_sv``
    use : ndarray of bool, shape (n, k)

    Returns
    -------
    ndarray, shape (n, 4), [x, y, z, c dt_rx] (m); zeros (the Earth's centre) for an
    epoch of fewer than four rows or without a root near the surface.
    """
    lor = np.array([1.0, 1.0, 1.0, -1.0])
    a = np.where(use[..., None], np.concatenate([sat_pos, rho[..., None]], axis=-1), 0.0)
    alpha = 0.5 * np.sum(a * a * lor, axis=-1)
    enough = use.sum(axis=1) >= 4
    nmat = a.transpose(0, 2, 1) @ a
    nmat[~enough] = np.eye(4)
    rhs = np.stack([a.sum(axis=1), (a * alpha[..., None]).sum(axis=1)], axis=-1)
    sol = np.linalg.solve(nmat, rhs)
    u, v = sol[..., 0], sol[..., 1]
    qa = 0.5 * np.sum(u * u * lor, axis=-1)
    qb = np.sum(u * v * lor, axis=-1) - 1.0
    qc = 0.5 * np.sum(v * v * lor, axis=-1)
    disc = qb * qb - 4.0 * qa * qc
    ok = enough & (disc >= 0.0) & (qa != 0.0)
    root = np.sqrt(np.where(ok, disc, 0.0))
    out, best = np.zeros((len(rho), 4)), np.zeros(len(rho))
    low, high = BANCROFT_SURFACE_M
    for sign in (1.0, -1.0):
        lam = (-qb + sign * root) / np.where(ok, 2.0 * qa, 1.0)
        y = (v + lam[:, None] * u) * lor
        radius = np.sqrt(np.sum(y[:, :3] ** 2, axis=1))
        # the satellites above the horizon (the other root can be the Earth's far side)
        sight = sat_pos - y[:, None, :3]
        up = np.sum(sight * y[:, None, :3], axis=-1) / (
            np.sqrt(np.sum(sight**2, axis=-1)) * np.where(radius > 0.0, radius, 1.0)[:, None]
        )
        score = np.sum(np.where(use, up, 0.0), axis=1) / np.maximum(use.sum(axis=1), 1)
        take = ok & (radius > low) & (radius < high) & (score > best)
        out[take], best[take] = y[take], score[take]
    return out


def _model_terms(los, rx_pos, sow, signal, options, scale=1.0):
    """Elevation, azimuth, troposphere and ionosphere (m) per padded row; ``rx_pos`` (n, 1, 3).

    The elevation and azimuth of :func:`inins.gnss.propagation.elevation_azimuth`, with
    the receiver's geodetic position computed once per epoch for both."""
    lla = earth.llh_from_ecef(rx_pos[:, 0, :])
    los_n = los @ earth.mat_en(lla[:, 0], lla[:, 1])  # mat_en^T los per epoch
    el = np.arcsin(np.clip(-los_n[..., 2], -1.0, 1.0))
    az = np.mod(np.arctan2(los_n[..., 1], los_n[..., 0]), 2.0 * np.pi)
    delay = np.zeros_like(el)
    if options.troposphere:
        delay += propagation.troposphere_saastamoinen(lla[:, 2:3], lla[:, 0:1], el)
    if options.klobuchar is not None:
        alpha, beta = options.klobuchar
        iono = propagation.ionosphere_klobuchar(
            sow[:, None], lla[:, 0:1], lla[:, 1:2], el, az, alpha, beta
        )
        delay += np.where(signal == Signal.L1, iono * scale, 0.0)
    return el, az, delay


def _weights(el, near, m, options):
    sin_el = np.where(
        near[:, None] & options.elevation_weights, np.sin(np.clip(el, 1e-3, None)), 1.0
    )
    ok = m.use & (~near[:, None] | (el >= m.mask))
    return np.where(ok, sin_el**2 / (options.sigma_zenith_m * m.sigma_scale) ** 2, 0.0), ok


def _normal(h, w, v):
    hw = h * w[..., None]
    hw_t = hw.transpose(0, 2, 1)
    return hw_t @ h, (hw_t @ v[..., None])[..., 0]


@dataclass(frozen=True)
class _Padded:
    """Measurements of n epochs padded to k slots: (n, k[, 3]); ``use`` False in the padding.

    ``system`` is the column of each slot's inter-system bias (-1: none, the first system);
    ``mask`` (rad) and ``sigma_scale`` per slot; ``iono`` the Klobuchar scale per slot.
    """

    sat_pos: np.ndarray
    pr: np.ndarray
    clk: np.ndarray
    signal: np.ndarray
    use: np.ndarray
    sow: np.ndarray
    system: np.ndarray
    mask: np.ndarray
    sigma_scale: np.ndarray
    iono: np.ndarray
    n_isb: int

    def take(self, k, use=None):
        return _Padded(
            self.sat_pos[k],
            self.pr[k],
            self.clk[k],
            self.signal[k],
            self.use[k] if use is None else use,
            self.sow[k],
            self.system[k],
            self.mask[k],
            self.sigma_scale[k],
            self.iono[k],
            self.n_isb,
        )


class _Fit(NamedTuple):
    """State of the batch least squares: x (n, 4 + j) [m, m, m, m, m...]; per slot (n, k):
    residual v (m), weight w (1/m^2), ok (used), el, az (rad); design h (n, k, 4 + j);
    done (n,); active (n, j) inter-system bias columns estimated in each epoch."""

    x: np.ndarray
    v: np.ndarray
    w: np.ndarray
    ok: np.ndarray
    el: np.ndarray
    az: np.ndarray
    h: np.ndarray
    done: np.ndarray
    active: np.ndarray

    def take(self, k):
        return _Fit(*(a[k] for a in self))

    def put(self, k, other):
        """A copy with the epochs ``k`` replaced by ``other``'s."""
        arrays = [a.copy() for a in self]
        for a, b in zip(arrays, other, strict=True):
            a[k] = b
        return _Fit(*arrays)

    @property
    def n_par(self):
        """Unknowns of each epoch (n,): position, clock and the active biases."""
        return 4 + self.active.sum(axis=1)


def _pad(epochs, rows, options):
    have = rows >= 0
    r = np.where(have, rows, 0)
    obs = epochs.obs
    pr = np.where(have, obs.pseudorange[r], np.nan)
    system = systems.system_of(obs.prn)
    present = np.flatnonzero(np.bincount(system, minlength=1))  # systems observed, sorted
    column = np.full(systems.SBAS + 1, -1, np.int64)
    column[present[1:]] = np.arange(len(present) - 1)
    mask = np.full(systems.SBAS + 1, options.mask_rad)
    scale = np.ones(systems.SBAS + 1)
    for s, value in options.system_mask_rad:
        mask[s] = value
    for s, value in options.system_sigma_scale:
        scale[s] = value
    slot_system = np.where(have, system[r], present[0] if len(present) else 0)
    return _Padded(
        sat_pos=np.where(have[..., None], epochs.sat_pos[r], [2.0e7, 0.0, 0.0]),
        pr=pr,
        clk=np.where(have, epochs.sat_clock[r], 0.0),
        signal=np.where(have, obs.signal[r], Signal.IONO_FREE),
        use=have & np.isfinite(pr),
        sow=obs.time,
        system=column[slot_system],
        mask=mask[slot_system],
        sigma_scale=scale[slot_system] * _snr_scale(obs.snr, r, have, options),
        iono=systems.iono_scale(np.where(have, obs.prn[r], 1)),
        n_isb=len(present) - 1,
    )


def _snr_scale(snr, r, have, options):
    """Sigma factor of each slot from its carrier-to-noise density (1 when off or absent)."""
    if options.snr_reference_dbhz is None:
        return 1.0
    cn0 = np.where(have, snr[r], np.nan)
    factor = np.sqrt(10.0 ** ((options.snr_reference_dbhz - cn0) / 10.0))
    return np.where(np.isfinite(factor), np.maximum(factor, 1.0), 1.0)


def _active(ok, m):
    """(n, j): bias column j is estimated where its system has used rows and is not the
    lowest system present (that one carries the receiver clock)."""
    j = m.n_isb
    if j == 0:
        return np.zeros((len(ok), 0), bool)
    onehot = m.system[..., None] == np.arange(j)  # (n, k, j)
    present = (onehot & ok[..., None]).any(axis=1)
    base_used = (ok & (m.system < 0)).any(axis=1)
    first = np.argmax(present, axis=1)
    lowest = np.zeros_like(present)
    lowest[np.arange(len(ok)), first] = ~base_used & present.any(axis=1)
    return present & ~lowest


def _linearize(x, m, options):
    """Residuals, weights, used slots, elevation, azimuth, design matrix and active bias
    columns at ``x`` (n, 4 + j)."""
    rx = x[:, None, :3]
    rng, los, _ = propagation.range_los(m.sat_pos, rx)
    near = np.linalg.norm(x[:, :3], axis=1) > NEAR_EARTH_M
    el, az, delay = _model_terms(los, rx, m.sow, m.signal, options, m.iono)
    delay = np.where(near[:, None], delay, 0.0)
    w, ok = _weights(el, near, m, options)
    h = np.concatenate([-los, np.ones_like(rng)[..., None]], axis=-1)
    active = _active(ok, m)
    if m.n_isb:
        ind = (m.system[..., None] == np.arange(m.n_isb)) & active[:, None, :]
        h = np.concatenate([h, ind.astype(float)], axis=-1)
        bias = np.einsum("nkj,nj->nk", ind, x[:, 4:])
    else:
        bias = 0.0
    v = m.pr - (rng + x[:, 3:4] + bias - m.clk + delay)
    return v, w, ok, el, az, h, near, active


def _solve_normal(nmat, rhs, active, enough):
    """Solve the stacked normal equations; inactive bias columns and epochs without
    enough rows get an identity block (their step is zero)."""
    size = nmat.shape[-1]
    eye = np.eye(size)
    free = np.concatenate([np.zeros((len(nmat), 4), bool), ~active], axis=1)
    nmat = nmat + free[:, :, None] * eye
    nmat[~enough] = eye
    rhs = np.where(free | ~enough[:, None], 0.0, rhs)
    return np.linalg.solve(nmat, rhs[..., None])[..., 0]


def _iterate(x, m, options):
    """Gauss-Newton on all epochs at once, from ``x`` (n, 4 + j), on the padded
    measurements ``m``. The returned residuals are evaluated at the final ``x``."""
    done = np.zeros(len(x), bool)
    todo = np.arange(len(x))  # epochs still iterated: neither converged nor short of rows
    x = x.copy()
    for _ in range(options.max_iterations):
        sub = m.take(todo)
        v, w, ok, _, _, h, near, active = _linearize(x[todo], sub, options)
        nmat, rhs = _normal(h, np.where(np.isfinite(v), w, 0.0), np.nan_to_num(v))
        enough = ok.sum(axis=1) >= 4 + active.sum(axis=1)
        dx = _solve_normal(nmat, rhs, active, enough)
        x[todo] = x[todo] + dx
        converged = (np.abs(dx).max(axis=1) < 1e-4) & near
        done[todo] = converged
        todo = todo[enough & ~converged]
        if not todo.size:
            break
    v, w, ok, el, az, h, _, active = _linearize(x, m, options)
    return _Fit(x, v, w, ok, el, az, h, done, active)


def _w_test(h, w, v, ok, active):
    """Normalised residuals ``v_i / sqrt(Q_vv,ii)`` with ``Q_vv = W^-1 - H N^-1 H^T``."""
    nmat, _ = _normal(h, w, v)
    free = np.concatenate([np.zeros((len(nmat), 4), bool), ~active], axis=1)
    ninv = np.linalg.inv(nmat + free[:, :, None] * np.eye(nmat.shape[-1]))
    hq = np.sum((h @ ninv) * h, axis=-1)
    qvv = np.where(ok, 1.0 / np.where(w > 0, w, 1.0) - hq, np.inf)
    return np.where(ok & (qvv > 1e-12), np.abs(v) / np.sqrt(np.abs(qvv)), 0.0)


def _chi2_fail(w, v, ok, false_alarm, n_par):
    dof = ok.sum(axis=1) - n_par
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
    padded = _pad(epochs, rows, options)
    x0 = np.zeros((n, 4 + padded.n_isb))
    if initial is not None:
        x0[:, :3] = initial
    else:  # the iteration converges to the same point from either, in fewer steps
        x0[:, :4] = bancroft(padded.sat_pos, padded.pr + padded.clk, padded.use)
    fit = _iterate(x0, padded, options)
    status = np.where(fit.done, FixStatus.FIX, FixStatus.NOT_CONVERGED).astype(np.int8)
    excluded = np.zeros(n, np.int64)
    n_excluded = np.zeros(n, np.int64)
    fail = _chi2_fail(fit.w, fit.v, fit.ok, options.false_alarm, fit.n_par)
    status[fail] = FixStatus.FAULT_DETECTED
    if options.exclude_faults and fail.any():
        fit, fixed, prn, count = _exclude(np.flatnonzero(fail), fit, padded, obs.prn, rows, options)
        status[fixed], excluded[fixed], n_excluded[fixed] = FixStatus.FAULT_EXCLUDED, prn, count
    no_fix = fit.ok.sum(axis=1) < fit.n_par
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
        pdop=np.where(no_fix, np.nan, _pdop(fit.h, fit.ok, fit.active)),
        residual_rms=np.where(no_fix, np.nan, rms),
        excluded_prn=excluded,
        n_excluded=n_excluded,
        isb=np.where(fit.active & ~no_fix[:, None], x[:, 4:], np.nan),
        isb_systems=tuple(np.flatnonzero(np.bincount(systems.system_of(obs.prn))).tolist()[1:]),
        used=used,
        **per_row,
    )


def _exclude(failed, fit, padded, prn, rows, options):
    """Exclude, one at a time and up to ``options.max_exclusions``, the satellite with the
    largest w-statistic in failed epochs that keep two rows of redundancy.

    Returns the fit with the epochs that pass after the exclusions replaced, those epochs
    (int array), the first PRN excluded in each and how many were excluded.
    """
    done_k, done_prn, done_count = [], [], []
    current = failed[fit.ok[failed].sum(axis=1) >= fit.n_par[failed] + 2]
    sub = fit.take(current)
    use = padded.use[current].copy()
    first = np.zeros(len(current), np.int64)
    for round_ in range(options.max_exclusions):
        if current.size == 0:
            break
        worst = np.argmax(_w_test(sub.h, sub.w, sub.v, sub.ok, sub.active), axis=1)
        use[np.arange(len(current)), worst] = False
        if round_ == 0:
            first = prn[rows[current, worst]]
        again = _iterate(sub.x, padded.take(current, use), options)
        passed = (
            ~_chi2_fail(again.w, again.v, again.ok, options.false_alarm, again.n_par) & again.done
        )
        fit = fit.put(current[passed], again.take(passed))
        done_k.append(current[passed])
        done_prn.append(first[passed])
        done_count.append(np.full(passed.sum(), round_ + 1))
        more = ~passed & (again.ok.sum(axis=1) >= again.n_par + 2)
        current, sub, use, first = current[more], again.take(more), use[more], first[more]
    if not done_k:
        return fit, np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64)
    return fit, np.concatenate(done_k), np.concatenate(done_prn), np.concatenate(done_count)


def _pdop(h, ok, active):
    """Position dilution of precision of the used, unweighted geometry."""
    nmat, _ = _normal(h, ok.astype(float), np.zeros(ok.shape))
    good = ok.sum(axis=1) >= 4 + active.sum(axis=1)
    size = nmat.shape[-1]
    free = np.concatenate([np.zeros((len(nmat), 4), bool), ~active], axis=1)
    nmat = nmat + free[:, :, None] * np.eye(size)
    nmat[~good] = np.eye(size)
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
