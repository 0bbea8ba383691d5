"""The filter loop as it was before the fused epoch kernel: one Python step per kernel.

A frozen copy of ``inins.ekf.filter.run_filter`` (and its ``_Run``, ``EpochLog``) as
of the commit before :func:`inins.ekf.fused.epoch` replaced the per-epoch Python glue:
it calls the building blocks one by one from Python, with the list-based log: the
kernels of :mod:`inins.ekf.step` the fused epoch composes (compensate, the strapdown,
mean rates, correct, feedback) and ``propagate`` and ``update`` of ``kernels``: the
package's (:mod:`inins.ekf.step`), or their copies as first written
(``frozen_kernels``).
``tests/ekf/test_fused_epoch.py`` runs it beside the fused filter on the same
epochs: with the package's kernels the outputs must be equal bit for bit (the
composition), with the frozen ones equal to rounding (the rewritten arithmetic). It
reads the sub-interval limits from :mod:`inins.ekf.filter`, so a test that moves them
moves both.
"""

from dataclasses import dataclass, field

import frozen_kernels
import numpy as np

from inins.core.satellites import LETTERS
from inins.core.stats import chi2_ppf
from inins.core.strapdown import FreeInertial
from inins.ekf import filter as ekf_filter
from inins.ekf import fused, rows, scoring, step
from inins.ekf.config import Coupling
from inins.ekf.result import EkfResult, Innovations
from inins.exceptions import InputError

_NAV = slice(0, 9)
SUB_STEPS = ekf_filter.SUB_STEPS


class package_kernels:
    """The package's ``propagate`` and ``update`` (:mod:`inins.ekf.step`) behind the
    argument lists of ``frozen_kernels``: the update's satellites and settings packed
    as :data:`inins.ekf.rows.Satellites` and :data:`inins.ekf.fused.TightModel`."""

    propagate = staticmethod(step.propagate)

    @staticmethod
    def update(x, P, quat, vel, lla, omega_b, lever_b, *args):
        """``frozen_kernels.update``'s arguments: the satellites' nine arrays (the order
        of :data:`inins.ekf.rows.Satellites` after its ``prn``), then
        ``bias_col, threshold, use_rr, init_clock, acc, y, s``."""
        bias_col, threshold, use_rr, init_clock, acc, y, s = args[9:]
        model = fused.TightModel(
            dt=0.0,
            window=1,
            noise=np.zeros(14),
            lever=lever_b,
            limits=np.zeros(2),
            threshold=float(threshold),
            use_rr=bool(use_rr),
            fb=False,
            keep=False,
            sens=np.zeros(0, np.int64),
            bias_columns=np.zeros(1, np.int64),
        )
        sats = rows.Satellites(np.zeros(len(args[2]), np.int64), *args[:9])
        nav = (quat, vel, lla)
        return step.update(x, P, nav, omega_b, model, sats, bias_col, init_clock, (acc, y, s))


def _sensor_index(n):
    """Sensor states in ``comp`` order ``[ba, bg, ma, mg]`` (EKF26) or ``[ba, bg]`` (EKF17)."""
    return np.r_[9:15, 17:26] if n == 26 else np.r_[9:15]


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

    def __init__(self, config, initial, t0, kernels):
        self.cfg = config
        self.kernels = kernels  # propagate and update
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
        self.limits = np.array([ekf_filter.RATE_CHANGE, ekf_filter.FORCE_CHANGE])
        self.offsets = {}  # interval length (samples) -> probe offsets before the PPS
        self.splits = 0  # intervals propagated sub-interval by sub-interval

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
            self.kernels.propagate(
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
        self.splits += 1
        total = np.eye(self.n) if self.keep_phi else None
        for j in range(SUB_STEPS):
            if total is not None and j:
                total = self.Phi @ total
            self.kernels.propagate(
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
        self.kernels.update(
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


def run_stepwise(config, initial, t0, epochs, true_sensor=None, store=None, kernels=frozen_kernels):
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
    kernels : module
        Its ``propagate`` and ``update`` are called (``frozen_kernels`` or
        :class:`package_kernels`).

    Returns
    -------
    inins.ekf.result.EkfResult
    int
        Intervals propagated over sub-intervals.

    Raises
    ------
    inins.exceptions.InputError
        If no epoch had a satellite (nothing to couple with).
    """
    cfg, run = config, _Run(config, initial, t0, kernels)
    run.keep_phi = store is not None
    fb = cfg.coupling is Coupling.FB
    log = EpochLog()
    wall = 0.0  # not timed: the tests compare the numbers, the bench the speed
    t_end = t0
    n = run.n
    for index, ep in enumerate(epochs):
        dth, dv = step.compensate(ep.dtheta, ep.dv, cfg.dt, run.comp) if fb else (ep.dtheta, ep.dv)
        start, series = run.nav.run(dth, dv, cfg.dt)
        t_k = ep.gnss.time
        # naive pairing updates the state at arrival itself: nothing to carry over
        tau = ep.gnss.arrival - t_k if cfg.pps_storage else 0.0
        t_state = t_k if cfg.pps_storage else ep.gnss.arrival
        t_end = ep.gnss.arrival
        p = ep.pps_index if cfg.pps_storage else dth.shape[0]
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
        log.update_s.append(0.0)  # the reference keeps no clock: timing is not compared
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
    if log.n_sats and max(log.n_sats) == 0:
        raise InputError("no satellites above the mask in any epoch of the run", key="gnss")
    result = EkfResult.from_log(cfg, log, t_end - t0, wall)
    if log.truth and len(log.truth) == len(log.time):
        result = scoring.truth_errors(
            result, log, true_sensor, pps_storage=cfg.pps_storage, systems=cfg.systems
        )
    return result, run.splits
