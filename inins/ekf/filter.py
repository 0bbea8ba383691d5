"""Tightly coupled INS/GPS EKF run (003): EKF1/EKF2, FF/FB, 1PPS timing, gating, outages.

Per epoch ``k`` (1PPS time ``t_k``, data arriving at ``t_k + tau``):

1. Strapdown (the compiled kernel of :func:`inins.core.strapdown.integrate`) over the
   IMU chunk up to the arrival; in FB the increments are first compensated with the
   cumulative sensor estimates, ``omega = (I - M_g) (omega_meas - b_g)`` (and alike
   for the accelerometers). The INS state after ``pps_index`` samples is the one
   stored at the PPS (003 §2.1).
2. Propagation over ``[t_{k-1}, t_k]``: ``F`` at the state in the middle of the
   interval with ``f_b``, ``omega_b`` moving-averaged over the dither window
   (003 §2.2, ``f_n = C_nb f_b`` eq. 6); third-order ``Phi``, series ``Qd``
   (:func:`inins.ekf.kernels.discretize`). When the rates change fast within the
   interval (a roll transient: ``omega_b`` or ``f_b`` at the middles of
   :data:`SUB_STEPS` sub-intervals differ from the mid-interval value by more than
   :data:`RATE_CHANGE` or :data:`FORCE_CHANGE`), ``F`` and ``Qd`` are evaluated
   on each sub-interval and the prediction made sub-interval by sub-interval
   (:func:`inins.ekf.step.propagate_split`).
3. Update at ``t_k`` with the stored state: scalar Joseph updates per pseudorange
   and range rate, each gated on chi-square(1) (:func:`inins.ekf.kernels.sequential_update`).
   The measurement is predicted at the corrected INS state ``nav (-) x``; epochs
   without satellites or inside an outage window are coasted. With several systems
   (:attr:`inins.ekf.config.FilterConfig.systems`) a pseudorange of a further system
   also has 1 at its inter-system bias state (appended after the 17 or 26 states,
   random walk, never reset by the feedback; docs/gnss.md).
4. FF: nothing else; the output is ``nav (-) x``. FB: the correction, carried over
   the latency by ``I + F tau``, is applied to the current INS state, the sensor
   estimates are added to the compensation, those states reset to zero and the
   cumulative corrections logged (003 §3.3.2).

``nav (-) dx``: ``lat - dr_N / (R_N + h)``, ``lon - dr_E / ((R_E + h) cos lat)``,
``h + dr_D``, ``v - dv``, ``mat_nb <- exp([phi x]) mat_nb`` (the phi-angle error
``mat_nb_est = (I - [phi x]) mat_nb_true`` of :mod:`inins.core.error_model`).

Epoch time: with 1PPS storage the update and the logged solution refer to the PPS
``t_k``; with the naive pairing (``pps_storage`` false) they refer to the INS state
at the data arrival ``t_k + tau``, and the result is labelled with that time and
scored against the truth there (the measurements of ``t_k`` pulled onto the state
of ``t_k + tau`` leave it ``v tau`` behind along track, which a score at ``t_k``
hides).

With truth (simulation) the output error, the heading error and the NEES of all
states are computed after the run (:func:`score`), vectorised over the epochs; the
navigation states estimate the INS error, so their estimation error is minus the
output error.
"""

import time as _time
from dataclasses import dataclass, field

import numpy as np

from inins.core import error_model, rotation
from inins.core.satellites import LETTERS
from inins.core.stats import chi2_ppf
from inins.core.strapdown import FreeInertial
from inins.ekf import step
from inins.ekf.config import Coupling
from inins.ekf.result import EkfResult, Innovations
from inins.exceptions import InputError

_NAV = slice(0, 9)
SUB_STEPS = 10
"""Sub-intervals probed (and used when the rates change fast) per propagation."""
RATE_CHANGE = 5.0 * np.pi / 180.0
"""rad/s: a change of ``omega_b`` within an interval beyond this splits the propagation
(the bank ripple of a turn flown as 15-deg track steps stays below; a roll in or out
within a second, ~100 deg/s, is far above)."""
FORCE_CHANGE = 2.0
"""m/s^2: a change of ``f_b`` within an interval beyond this splits the propagation."""


def _sensor_index(n):
    """Sensor states in ``comp`` order ``[ba, bg, ma, mg]`` (EKF26) or ``[ba, bg]`` (EKF17)."""
    return np.r_[9:15, 17:26] if n == 26 else np.r_[9:15]


def correct(quat, vel, lla, dx):
    """Navigation state minus the error estimate ``dx`` (first 9 states), module docstring.

    Returns quat (4,), vel (3,), lla (3,) as new arrays.
    """
    out = np.empty(4), np.empty(3), np.empty(3)
    step.correct(
        np.asarray(quat, float),
        np.asarray(vel, float),
        np.asarray(lla, float),
        np.asarray(dx, float),
        *out,
    )
    return out


def _state_at(start, series, index):
    """(quat, vel, lla) after ``index`` samples of a chunk (0: the chunk start)."""
    if index == 0:
        return start
    i = index - 1
    return series[0][i], series[1][i], series[2][i]


@dataclass
class EpochLog:
    """What a run records per epoch (``m`` epochs so far), stacked by :meth:`stack`.

    Attributes
    ----------
    time : list of float
        The time the logged state refers to (s): the PPS, or the arrival (naive pairing).
    gnss_time : list of float
        The measurement epoch (PPS) (s).
    quat, vel, lla : list of ndarray
        Output solution after the update, (4,), (3,), (3,).
    state, sigma, cumulative : list of ndarray
        Error-state estimate (sensor totals), its 1-sigma, FB cumulative corrections, (n,).
    covariance : list of ndarray
        ``P`` (n, n) after the update; kept only when the epochs carry truth (NEES).
    truth : list of TruthEpoch
    n_sats, n_used, n_rejected : list of int
    coasted : list of bool
    nis, update_s : list of float
    rows : list of tuple
        Per updated epoch: its index and the ``(prn, kind, innovation, variance,
        accepted)`` arrays of the scalar measurements used.
    """

    time: list = field(default_factory=list)
    gnss_time: list = field(default_factory=list)
    quat: list = field(default_factory=list)
    vel: list = field(default_factory=list)
    lla: list = field(default_factory=list)
    state: list = field(default_factory=list)
    sigma: list = field(default_factory=list)
    cumulative: list = field(default_factory=list)
    covariance: list = field(default_factory=list)
    truth: list = field(default_factory=list)
    n_sats: list = field(default_factory=list)
    n_used: list = field(default_factory=list)
    n_rejected: list = field(default_factory=list)
    coasted: list = field(default_factory=list)
    nis: list = field(default_factory=list)
    update_s: list = field(default_factory=list)
    rows: list = field(default_factory=list)

    def innovations(self):
        """:class:`~inins.ekf.result.Innovations` of every scalar measurement processed."""

        def cat(i, dtype):
            parts = [r[i] for r in self.rows]
            return np.concatenate(parts).astype(dtype) if parts else np.zeros(0, dtype)

        sizes = [r[2].size for r in self.rows]
        return Innovations(
            np.repeat(np.array([r[0] for r in self.rows], np.int64), sizes),
            cat(1, np.int64),
            cat(2, np.int8),
            cat(3, float),
            cat(4, float),
            cat(5, bool),
        )


class _Run:
    """Mutable state of one filter run (kept out of the public API)."""

    def __init__(self, config, initial, t0):
        self.cfg = config
        n = self.n = len(config.layout)
        base = len(config.model.layout)  # 17 or 26; inter-system biases after them
        self.keep_phi = False  # accumulate Phi over sub-intervals (a smoother's store)
        self.x = np.zeros(n)
        self.P = config.initial_sigma.covariance(base, n - base)
        self.comp = np.zeros(15)
        self.cum = np.zeros(9)
        self.sens = _sensor_index(base)
        self.bias_columns = config.bias_columns()
        self.nav = FreeInertial(initial)
        self.t_prev = t0
        self.clock_ready = False
        self.rates = np.zeros((2, 3))  # omega_b, f_b at the last PPS (dither-filtered)
        self.rates_sub = np.zeros((SUB_STEPS + 1, 2, 3))
        self.F, self.Qc, self.Phi, self.Qd = (np.zeros((n, n)) for _ in range(4))
        # chi-square(1) quantile: P(chi2_1 <= threshold) = gate_probability
        self.threshold = float(chi2_ppf(config.gate_probability, 1))
        self.noise = np.concatenate(
            [
                config.arw,
                config.vrw,
                config.accel_bias_rw,
                config.gyro_bias_rw,
                [config.clock_bias_psd, config.clock_drift_psd],
                [config.system_bias_psd] * (n - base),
            ]
        )
        self.lever = np.asarray(config.lever_arm, dtype=float)
        self.limits = np.array([RATE_CHANGE, FORCE_CHANGE])
        self.offsets = {}  # interval length (samples) -> probe offsets before the PPS

    def propagate(self, start, series, dth, dv, p, dt_k):
        """Predict over ``dt_k`` ending at sample ``p`` of the chunk (module docstring, 2)."""
        cfg = self.cfg
        span = round(dt_k / cfg.dt)
        offsets = self.offsets.get(span)
        if offsets is None:  # sub-interval middles, then the whole interval's, before p
            offsets = np.append(
                span - (2 * np.arange(SUB_STEPS) + 1) * span // (2 * SUB_STEPS),
                round(0.5 * dt_k / cfg.dt),
            )
            self.offsets[span] = offsets
        probes = np.maximum(p - offsets, 0)
        mids, mid = probes[:SUB_STEPS], int(probes[SUB_STEPS])
        step.mean_rates_at(dth, dv, probes, cfg.dither_window, cfg.dt, self.rates_sub)
        split = dt_k > 0.0 and step.rates_change(self.rates_sub, self.limits)
        self.Phi_k = self.Phi  # the interval's transition (for a smoother's store)
        if not split:
            step.propagate(
                self.x,
                self.P,
                self.F,
                self.Qc,
                self.Phi,
                self.Qd,
                *_state_at(start, series, mid),
                self.rates_sub[-1, 0],
                self.rates_sub[-1, 1],
                dt_k,
                self.noise,
            )
            return
        total = np.eye(self.n) if self.keep_phi else None
        for j in range(SUB_STEPS):
            if total is not None and j:
                total = self.Phi @ total
            step.propagate(
                self.x,
                self.P,
                self.F,
                self.Qc,
                self.Phi,
                self.Qd,
                *_state_at(start, series, int(mids[j])),
                self.rates_sub[j, 0],
                self.rates_sub[j, 1],
                dt_k / SUB_STEPS,
                self.noise,
            )
        if total is not None:
            self.Phi_k = self.Phi @ total

    def update(self, gnss, quat, vel, lla, omega_b):
        """Measurement update at the stored PPS state; per-row arrays of the rows used."""
        k = len(gnss)
        rows = np.arange(2 * k) if self.cfg.use_range_rate else np.arange(0, 2 * k, 2)
        acc = np.zeros(rows.size, dtype=np.bool_)
        y, s = np.empty(rows.size), np.empty(rows.size)
        bias_col = self.bias_columns[gnss.system]
        if bias_col.min() < -1:
            letters = sorted({LETTERS[i] for i in gnss.system[bias_col < -1].tolist()})
            raise InputError(
                f"satellites of system {''.join(letters)} at t = {gnss.time:.3f} s, which the "
                f"filter does not take (systems {self.cfg.systems})",
                key="systems",
            )
        step.update(
            self.x,
            self.P,
            quat,
            vel,
            lla,
            omega_b,
            self.lever,
            gnss.sat_pos,
            gnss.sat_vel,
            gnss.pseudorange,
            gnss.sat_clock,
            gnss.delay,
            gnss.range_rate,
            gnss.sat_clock_drift,
            gnss.sigma_pr,
            gnss.sigma_rr,
            bias_col,
            self.threshold,
            self.cfg.use_range_rate,
            not self.clock_ready,
            acc,
            y,
            s,
        )
        self.clock_ready = True
        return rows, acc, y, s

    def feedback(self, tau):
        """FB: apply the correction to the current state (carried over ``tau``), reset."""
        nav = self.nav
        step.feedback(
            self.x, self.F, tau, nav.quat, nav.vel, nav.lla, self.comp, self.cum, self.sens
        )


def run_filter(config, initial, t0, epochs, true_sensor=None, store=None):
    """Run the tightly coupled filter over a stream of epochs (module docstring).

    Parameters
    ----------
    config : inins.ekf.config.FilterConfig
    initial : inins.core.strapdown.NavState
        Aligned INS state at ``t0`` (e.g. from :func:`inins.ekf.flight.gyrocompass_attitude`).
    t0 : float
        Time of ``initial`` (s), on the IMU time axis of the epochs.
    epochs : iterable of inins.ekf.config.EpochInput
        Consecutive chunks, PPS times increasing; consumed once (may be a generator).
        With truth (:class:`~inins.ekf.config.TruthEpoch`) the run is scored after
        it (:func:`score`); with the naive pairing the truth needs its ``at_arrival``.
    true_sensor : inins.core.imu.SensorErrors, optional
        Constant true sensor errors, for the NEES of the sensor states when the
        epochs carry truth.
    store : inins.ekf.tight_store.TightStore, optional
        Records what an RTS smoother needs per epoch.

    Returns
    -------
    inins.ekf.result.EkfResult

    Raises
    ------
    inins.exceptions.InputError
        If no epoch had a satellite (nothing to couple with).
    """
    cfg, run = config, _Run(config, initial, t0)
    run.keep_phi = store is not None
    fb = cfg.coupling is Coupling.FB
    log = EpochLog()
    wall = 0.0  # the filter's own time: producing the epochs (simulation, file) is not counted
    t_end = t0
    n = run.n
    for index, ep in enumerate(epochs):
        start_wall = _time.perf_counter()
        dth, dv = step.compensate(ep.dtheta, ep.dv, cfg.dt, run.comp) if fb else (ep.dtheta, ep.dv)
        start, series = run.nav.run(dth, dv, cfg.dt)
        t_k = ep.gnss.time
        # naive pairing updates the state at arrival itself: nothing to carry over
        tau = ep.gnss.arrival - t_k if cfg.pps_storage else 0.0
        t_state = t_k if cfg.pps_storage else ep.gnss.arrival
        t_end = ep.gnss.arrival
        p = ep.pps_index if cfg.pps_storage else dth.shape[0]
        tick = _time.perf_counter()
        run.propagate(start, series, dth, dv, p, t_state - run.t_prev)
        if store is not None:
            store.predicted(run.P, run.Phi_k)
        quat, vel, lla = _state_at(start, series, p)
        step.mean_rates(dth, dv, p, cfg.dither_window, cfg.dt, run.rates)
        coasted = len(ep.gnss) == 0 or cfg.in_outage(t_k)
        update = None if coasted else run.update(ep.gnss, quat, vel, lla, run.rates[0])
        out = np.empty(4), np.empty(3), np.empty(3)
        step.correct(quat, vel, lla, run.x, *out)
        estimate = run.x.copy()
        estimate[run.sens] += run.comp[: run.sens.size]
        if coasted:
            log.n_used.append(0)
            log.n_rejected.append(0)
            log.nis.append(0.0)
        else:
            rows, acc, y, s = update
            used = int(np.count_nonzero(acc))
            log.n_used.append(used)
            log.n_rejected.append(acc.size - used)
            log.nis.append(float(np.dot(y * y / s, acc)))
            log.rows.append((index, ep.gnss.prn[rows // 2], rows % 2, y, s, acc))
        log.state.append(estimate)
        log.sigma.append(np.sqrt(run.P.ravel()[:: n + 1]))  # the diagonal
        if ep.truth is not None:
            log.truth.append(ep.truth)
            log.covariance.append(run.P.copy())
        if store is not None:
            after = run.comp.copy()
            if fb and not coasted:
                after[: run.sens.size] += run.x[run.sens]
            reset = np.r_[0:9, run.sens]
            store.updated(
                t_state, run.x, run.P, reset, fb and not coasted, (quat, vel, lla), out, after
            )
        if fb and not coasted:
            run.feedback(tau)
        log.update_s.append(_time.perf_counter() - tick)
        run.t_prev = t_state
        cum = np.zeros(n)
        cum[_NAV] = run.cum
        cum[run.sens] = run.comp[: run.sens.size]
        log.time.append(t_state)
        log.gnss_time.append(t_k)
        log.quat.append(out[0])
        log.vel.append(out[1])
        log.lla.append(out[2])
        log.n_sats.append(len(ep.gnss))
        log.coasted.append(coasted)
        log.cumulative.append(cum)
        wall += _time.perf_counter() - start_wall
    if log.n_sats and max(log.n_sats) == 0:
        raise InputError("no satellites above the mask in any epoch of the run", key="gnss")
    result = EkfResult.from_log(cfg, log, t_end - t0, wall)
    if log.truth and len(log.truth) == len(log.time):
        result = score(result, log, true_sensor, pps_storage=cfg.pps_storage, systems=cfg.systems)
    return result


def _bias_names(layout):
    """The inter-system bias states of a layout (the last states)."""
    return tuple(n for n in layout.names if n in error_model.SYSTEM_BIASES)


def _true_biases(truths, names, systems):
    """(m, 1 + len(names)) true biases: the reference system's (the clock carries it),
    then each bias state's (its system's minus the reference's); None if no truth
    carries a ``system_bias`` (one without counts as no bias)."""
    if all(t.system_bias is None for t in truths):
        return None
    index = [LETTERS.index(systems[0])] + [LETTERS.index(n[-1]) for n in names]
    zero = np.zeros(len(LETTERS))
    b = np.array([zero if t.system_bias is None else t.system_bias for t in truths])
    b = b.reshape(-1, len(LETTERS))[:, index]
    b[:, 1:] -= b[:, :1]
    return b


def score(result, log, true_sensor=None, *, pps_storage=True, systems="G"):
    """The result with its errors against truth: output error, heading error, NEES.

    Vectorised over the epochs, after the run. The navigation truth is the one at
    ``result.time`` (the PPS, or the arrival with the naive pairing: the truth's
    ``at_arrival``); the clock truth the one at the measurement epoch.

    Parameters
    ----------
    result : inins.ekf.result.EkfResult
    log : EpochLog
        With one :class:`~inins.ekf.config.TruthEpoch` and ``P`` per epoch.
    true_sensor : inins.core.imu.SensorErrors, optional
        Constant true sensor errors: with them the NEES of all states.
    pps_storage : bool
    systems : str
        The filter's systems (:class:`~inins.ekf.config.FilterConfig`), the first the
        reference of the inter-system biases.

    Returns
    -------
    inins.ekf.result.EkfResult
    """
    truths = log.truth
    if not pps_storage:
        if any(t.at_arrival is None for t in truths):
            raise ValueError("the naive pairing is scored with the truth at the data arrival")
        nav = [t.at_arrival for t in truths]
    else:
        nav = [(t.mat_nb, t.vel_n, t.lla) for t in truths]
    mat_true = np.array([v[0] for v in nav]).reshape(-1, 3, 3)
    vel_true = np.array([v[1] for v in nav]).reshape(-1, 3)
    lla_true = np.array([v[2] for v in nav]).reshape(-1, 3)
    mat_est = rotation.mat_from_quat(result.quat_nb)
    err = np.concatenate(
        [
            error_model.position_error_ned(result.lla, lla_true),
            result.vel_n - vel_true,
            error_model.attitude_error(mat_est, mat_true),
        ],
        axis=1,
    )
    heading = rotation.euler_from_mat(mat_est)[:, 2] - rotation.euler_from_mat(mat_true)[:, 2]
    nees = np.zeros(0)
    if true_sensor is not None:
        n = result.state.shape[1]
        clock = np.array([[t.clock_bias, t.clock_drift] for t in truths]).reshape(-1, 2)
        base = n - len(_bias_names(result.layout))
        biases = _true_biases(truths, _bias_names(result.layout), systems)
        if biases is not None:
            clock[:, 0] += biases[:, 0]  # the clock carries the reference system's bias
        true = np.concatenate(
            [
                np.zeros((len(truths), 9)),
                np.tile(
                    np.concatenate([true_sensor.accel_bias, true_sensor.gyro_bias]),
                    (len(truths), 1),
                ),
                clock,
                np.tile(
                    np.concatenate([true_sensor.accel_misalignment, true_sensor.gyro_misalignment]),
                    (len(truths), 1),
                ),
            ],
            axis=1,
        )[:, :base]
        if biases is not None:
            true = np.concatenate([true, biases[:, 1:]], axis=1)
        # the navigation states estimate the INS error: their estimation error is minus
        # the output error; sensor and clock states estimate the quantity itself
        e = result.state - true
        e[:, :9] = -err
        P = np.array(log.covariance)
        nees = np.einsum("mi,mi->m", e, np.linalg.solve(P, e[..., None])[..., 0])
    return result.with_truth(err, rotation.wrap_angle(heading), nees)
