"""Tightly coupled INS/GPS EKF run (003): EKF1/EKF2, FF/FB, 1PPS timing, gating, outages.

Per epoch ``k`` (1PPS time ``t_k``, data arriving at ``t_k + tau``):

1. Strapdown (the compiled kernel of :func:`inins.core.strapdown.integrate`) over the
   IMU chunk up to the arrival; in FB the increments are first compensated with the
   cumulative sensor estimates, ``omega = (I - M_g) (omega_meas - b_g)`` (and alike
   for the accelerometers). The INS state after ``pps_index`` samples is the one
   stored at the PPS (003 §2.1).
2. Propagation once per epoch: ``F`` at the state in the middle of
   ``[t_{k-1}, t_k]`` with ``f_b``, ``omega_b`` moving-averaged over the dither
   window (003 §2.2, ``f_n = C_nb f_b`` eq. 6); third-order ``Phi``, series ``Qd``
   (:func:`inins.ekf.kernels.discretize`).
3. Update at ``t_k`` with the stored state: scalar Joseph updates per pseudorange
   and range rate, each gated on chi-square(1) (:func:`inins.ekf.kernels.sequential_update`).
   The measurement is predicted at the corrected INS state ``nav (-) x``; epochs
   without satellites or inside an outage window are coasted.
4. FF: nothing else; the output is ``nav (-) x``. FB: the correction, carried over
   the latency by ``I + F tau``, is applied to the current INS state, the sensor
   estimates are added to the compensation, those states reset to zero and the
   cumulative corrections logged (003 §3.3.2).

``nav (-) dx``: ``lat - dr_N / (R_N + h)``, ``lon - dr_E / ((R_E + h) cos lat)``,
``h + dr_D``, ``v - dv``, ``mat_nb <- exp([phi x]) mat_nb`` (the phi-angle error
``mat_nb_est = (I - [phi x]) mat_nb_true`` of :mod:`inins.core.error_model`).

With truth (simulation) each epoch also gets the output error, the heading error
and the NEES of all states; the navigation states estimate the INS error, so
their estimation error is minus the output error.
"""

import time as _time

import numpy as np
from scipy import stats

from inins.core import error_model, kalman, rotation, strapdown
from inins.ekf import step
from inins.ekf.config import Coupling
from inins.ekf.result import EkfResult
from inins.exceptions import InputError

_NAV = slice(0, 9)


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


class _Strapdown:
    """Free-inertial navigation state carried through chunks without per-chunk objects.

    Runs the compiled kernel behind :func:`inins.core.strapdown.integrate` on plain
    arrays (mode free, coning and sculling on, every sample kept), which that
    function documents as exact in chunks; ``tests/ekf/test_step.py`` checks the
    result equals ``integrate`` bit for bit.
    """

    _HOME = np.zeros(8)  # Earth terms of fixed-position modes; unused in free mode

    def __init__(self, state):
        self.quat = state.quat_nb.copy()
        self.vel = state.vel_n.copy()
        self.lla = state.lla.copy()
        self.prev = np.concatenate([state.dtheta_prev, state.dv_prev])
        self.count = state.count

    def run(self, dtheta, dv, dt):
        """Integrate a chunk; returns the states after each sample, (n, 4), (n, 3), (n, 3)."""
        n = dtheta.shape[0]
        out = (np.empty(n, np.int64), np.empty((n, 4)), np.empty((n, 3)), np.empty((n, 3)))
        start = (self.quat.copy(), self.vel.copy(), self.lla.copy())
        strapdown._navigate(
            self.quat,
            self.vel,
            self.lla,
            self.prev,
            self.count,
            np.ascontiguousarray(dtheta),
            np.ascontiguousarray(dv),
            float(dt),
            0,
            True,
            True,
            1,
            self._HOME,
            *out,
        )
        self.count += n
        return start, out[1:]

    def state(self):
        """The current state as a :class:`inins.core.strapdown.NavState`."""
        return strapdown.NavState(
            self.quat.copy(),
            self.vel.copy(),
            self.lla.copy(),
            self.prev[:3].copy(),
            self.prev[3:].copy(),
            self.count,
        )


def _state_at(start, series, index):
    """(quat, vel, lla) after ``index`` samples of a chunk (0: the chunk start)."""
    if index == 0:
        return start
    i = index - 1
    return series[0][i], series[1][i], series[2][i]


def _truth_error(truth, out, estimate, true_sensor):
    """Error (estimate - truth) of the output and, with ``true_sensor``, of the sensor and
    clock states (else zeros there), shape (n,)."""
    quat, vel, lla = out
    n = estimate.size
    e = np.zeros(n)
    if true_sensor is not None:
        true = np.concatenate(
            [
                np.zeros(9),
                true_sensor.accel_bias,
                true_sensor.gyro_bias,
                [truth.clock_bias, truth.clock_drift],
                true_sensor.accel_misalignment,
                true_sensor.gyro_misalignment,
            ]
        )
        e = estimate - true[:n]
    e[0:3] = error_model.position_error_ned(lla, truth.lla)
    e[3:6] = vel - truth.vel_n
    e[6:9] = error_model.attitude_error(rotation.mat_from_quat(quat), truth.mat_nb)
    return e


class _Run:
    """Mutable state of one filter run (kept out of the public API)."""

    def __init__(self, config, initial, t0):
        self.cfg = config
        n = self.n = len(config.layout)
        self.x = np.zeros(n)
        self.P = config.initial_sigma.covariance(n)
        self.comp = np.zeros(15)
        self.cum = np.zeros(9)
        self.sens = _sensor_index(n)
        self.nav = _Strapdown(initial)
        self.t_prev = t0
        self.clock_ready = False
        self.rates = np.zeros((2, 3))  # omega_b, f_b at the last PPS (dither-filtered)
        self.rates_mid = np.zeros((2, 3))
        self.F, self.Qc, self.Phi, self.Qd = (np.zeros((n, n)) for _ in range(4))
        self.threshold = float(stats.chi2.ppf(config.gate_probability, 1))
        self.noise = np.concatenate(
            [
                config.arw,
                config.vrw,
                config.accel_bias_rw,
                config.gyro_bias_rw,
                [config.clock_bias_psd, config.clock_drift_psd],
            ]
        )
        self.lever = np.asarray(config.lever_arm, dtype=float)

    def update(self, gnss, quat, vel, lla, omega_b):
        """Measurement update at the stored PPS state; per-row arrays of the rows used."""
        k = len(gnss)
        meas = np.stack(
            [
                gnss.pseudorange,
                gnss.sat_clock,
                gnss.delay,
                gnss.range_rate,
                gnss.sat_clock_drift,
                gnss.sigma_pr,
                gnss.sigma_rr,
            ]
        )
        rows = np.arange(2 * k) if self.cfg.use_range_rate else np.arange(0, 2 * k, 2)
        acc = np.zeros(rows.size, dtype=np.bool_)
        y, s = np.empty(rows.size), np.empty(rows.size)
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
            meas,
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


def _log_epoch(log, run, index, ep, out, update, true_sensor):
    """Append the epoch's outputs (after its update, before an FB reset)."""
    estimate = run.x.copy()
    estimate[run.sens] += run.comp[: run.sens.size]
    if update is not None:
        rows, acc, y, s = update
        for key, value in (
            ("i_epoch", np.full(rows.size, index)),
            ("i_prn", ep.gnss.prn[rows // 2]),
            ("i_kind", rows % 2),
            ("i_value", y),
            ("i_variance", s),
            ("i_accepted", acc),
        ):
            log[key].append(value)
    if ep.truth is not None:
        e = _truth_error(ep.truth, out, estimate, true_sensor)
        log["err"].append(e[:9])
        if true_sensor is not None:
            # the navigation states estimate the INS error, so their estimation error
            # is minus the output error; sensor and clock states estimate the quantity
            e_state = np.concatenate([-e[:9], e[9:]])
            log["nees"].append(float(kalman.nees(e_state, run.P)))
        heading = rotation.euler_from_mat(rotation.mat_from_quat(out[0]))[2]
        true_heading = rotation.euler_from_mat(ep.truth.mat_nb)[2]
        log["heading_err"].append(float(rotation.wrap_angle(heading - true_heading)))
    log["sigma"].append(np.sqrt(np.diag(run.P)))
    log["state"].append(estimate)


def run_filter(config, initial, t0, epochs, true_sensor=None):
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
    true_sensor : inins.core.imu.SensorErrors, optional
        Constant true sensor errors, for the NEES of the sensor states when the
        epochs carry truth.

    Returns
    -------
    inins.ekf.result.EkfResult

    Raises
    ------
    inins.exceptions.InputError
        If no epoch had a satellite (nothing to couple with).
    """
    cfg, run = config, _Run(config, initial, t0)
    fb = cfg.coupling is Coupling.FB
    log = {
        k: []
        for k in (
            "time",
            "quat",
            "vel",
            "lla",
            "state",
            "sigma",
            "cum",
            "err",
            "nees",
            "heading_err",
            "n_sats",
            "n_used",
            "n_rejected",
            "coasted",
            "nis",
            "update_s",
            "i_epoch",
            "i_prn",
            "i_kind",
            "i_value",
            "i_variance",
            "i_accepted",
        )
    }
    wall = 0.0  # the filter's own time: producing the epochs (simulation, file) is not counted
    t_end = t0
    out = np.empty(4), np.empty(3), np.empty(3)
    for index, ep in enumerate(epochs):
        start_wall = _time.perf_counter()
        dth, dv = step.compensate(ep.dtheta, ep.dv, cfg.dt, run.comp) if fb else (ep.dtheta, ep.dv)
        start, series = run.nav.run(dth, dv, cfg.dt)
        t_k = ep.gnss.time
        # naive pairing updates the state at arrival itself: nothing to carry over
        tau = ep.gnss.arrival - t_k if cfg.pps_storage else 0.0
        t_end = ep.gnss.arrival
        p = ep.pps_index if cfg.pps_storage else dth.shape[0]
        mid = max(p - round(0.5 * (t_k - run.t_prev) / cfg.dt), 0)
        tick = _time.perf_counter()
        step.mean_rates(dth, dv, mid, cfg.dither_window, cfg.dt, run.rates_mid)
        step.propagate(
            run.x,
            run.P,
            run.F,
            run.Qc,
            run.Phi,
            run.Qd,
            *_state_at(start, series, mid),
            run.rates_mid[0],
            run.rates_mid[1],
            t_k - run.t_prev,
            run.noise,
        )
        quat, vel, lla = _state_at(start, series, p)
        step.mean_rates(dth, dv, p, cfg.dither_window, cfg.dt, run.rates)
        coasted = len(ep.gnss) == 0 or cfg.in_outage(t_k)
        update = None if coasted else run.update(ep.gnss, quat, vel, lla, run.rates[0])
        step.correct(quat, vel, lla, run.x, *out)
        n_used = 0 if coasted else int(update[1].sum())
        log["n_rejected"].append(0 if coasted else update[1].size - n_used)
        log["nis"].append(
            0.0 if coasted else float(np.sum(update[2][update[1]] ** 2 / update[3][update[1]]))
        )
        _log_epoch(log, run, index, ep, out, update, true_sensor)
        if fb and not coasted:
            run.feedback(tau)
        log["update_s"].append(_time.perf_counter() - tick)
        run.t_prev = t_k
        cum = np.zeros(run.n)
        cum[_NAV] = run.cum
        cum[run.sens] = run.comp[: run.sens.size]
        for key, value in (
            ("time", t_k),
            ("quat", out[0].copy()),
            ("vel", out[1].copy()),
            ("lla", out[2].copy()),
            ("n_sats", len(ep.gnss)),
            ("n_used", n_used),
            ("coasted", coasted),
            ("cum", cum),
        ):
            log[key].append(value)
        wall += _time.perf_counter() - start_wall
    if log["n_sats"] and max(log["n_sats"]) == 0:
        raise InputError("no satellites above the mask in any epoch of the run", key="gnss")
    return EkfResult.from_logs(cfg, log, t_end - t0, wall)
