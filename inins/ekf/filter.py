"""Tightly coupled INS/GPS EKF run (003): EKF1/EKF2, FF/FB, 1PPS timing, gating, outages.

Per epoch ``k`` (1PPS time ``t_k``, data arriving at ``t_k + tau``):

1. Strapdown (:func:`inins.core.strapdown.integrate`, numba) over the IMU chunk up
   to the arrival; in FB the increments are first compensated with the
   cumulative sensor estimates, ``omega = (I - M_g) (omega_meas - b_g)`` (and alike
   for the accelerometers). The INS state after ``pps_index`` samples is the one
   stored at the PPS (003 §2.1).
2. Propagation once per epoch: ``F`` at the state in the middle of
   ``[t_{k-1}, t_k]`` with ``f_b``, ``omega_b`` moving-averaged over the dither
   window (003 §2.2, ``f_n = C_nb f_b`` eq. 6); third-order ``Phi``, trapezoidal ``Qd``.
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
"""

import math
import time as _time

import numpy as np
from scipy import stats

from inins.core import earth, error_model, kalman, rotation, strapdown
from inins.ekf import kernels
from inins.ekf.config import Coupling
from inins.ekf.measurements import antenna
from inins.ekf.result import EkfResult, Innovations

_NAV, _SENS = slice(0, 9), np.r_[9:15, 17:26]


def correct(quat, vel, lla, dx):
    """Navigation state minus the error estimate ``dx`` (first 9 states), module docstring.

    Returns quat (4,), vel (3,), lla (3,) as new arrays.
    """
    rn, re = earth.principal_radii(lla[0])
    lla = np.array([lla[0] - dx[0] / (rn + lla[2]),
                    lla[1] - dx[1] / ((re + lla[2]) * math.cos(lla[0])), lla[2] + dx[2]])
    quat = rotation.quat_multiply(rotation.quat_from_rotvec(dx[6:9]), quat)
    return quat / np.linalg.norm(quat), vel - dx[3:6], lla


def _compensate(dtheta, dv, dt, comp):
    """Increments with the cumulative FB sensor estimates removed (module docstring)."""
    ba, bg, ma, mg = comp[0:3], comp[3:6], comp[6:9], comp[9:15]
    m_g = np.array([[0.0, mg[0], mg[1]], [mg[2], 0.0, mg[3]], [mg[4], mg[5], 0.0]])
    m_a = np.array([[0.0, 0.0, 0.0], [ma[0], 0.0, 0.0], [ma[1], ma[2], 0.0]])
    return ((dtheta - bg * dt) @ (np.eye(3) - m_g).T, (dv - ba * dt) @ (np.eye(3) - m_a).T)


def _mean_rates(dtheta, dv, centre, window, dt, prev):
    """Moving average of omega_b, f_b over ``window`` samples centred at ``centre``."""
    n = dtheta.shape[0]
    if n == 0:
        return prev
    lo = min(max(centre - window // 2, 0), max(n - window, 0))
    hi = min(lo + window, n)
    span = (hi - lo) * dt
    return dtheta[lo:hi].sum(axis=0) / span, dv[lo:hi].sum(axis=0) / span


def _state_at(start, series, index):
    """(quat, vel, lla) after ``index`` samples of a chunk (0: the chunk start)."""
    if index == 0:
        return start.quat_nb, start.vel_n, start.lla
    i = index - 1
    return series.quat_nb[i], series.vel_n[i], series.lla[i]


def _truth_error(truth, out, estimate, true_sensor):
    """Estimation error (estimate - truth) of the output and of the sensor and clock states."""
    quat, vel, lla = out
    n = estimate.size
    true = np.concatenate([np.zeros(9), true_sensor.accel_bias, true_sensor.gyro_bias,
                           [truth.clock_bias, truth.clock_drift],
                           true_sensor.accel_misalignment, true_sensor.gyro_misalignment])
    e = estimate - true[:n]
    e[0:3] = error_model.position_error_ned(lla, truth.lla)
    e[3:6] = vel - truth.vel_n
    e[6:9] = error_model.attitude_error(rotation.mat_from_quat(quat), truth.mat_nb)
    return e


class _Run:
    """Mutable state of one filter run (kept out of the public API)."""

    def __init__(self, config, initial, t0):
        self.cfg = config
        self.n = len(config.layout)
        self.x = np.zeros(self.n)
        self.P = config.initial_sigma.covariance(self.n)
        self.comp = np.zeros(15)
        self.cum_nav = np.zeros(9)
        self.nav = initial
        self.t_prev = t0
        self.clock_ready = False
        self.rates = (np.zeros(3), np.zeros(3))
        self.F = np.zeros((self.n, self.n))
        self.Qc = np.zeros((self.n, self.n))
        self.Phi = np.eye(self.n)
        self.Qd = np.zeros((self.n, self.n))
        self.threshold = float(stats.chi2.ppf(config.gate_probability, 1))
        self.noise = (config.arw, config.vrw, config.accel_bias_rw, config.gyro_bias_rw,
                      config.clock_bias_psd, config.clock_drift_psd)

    def propagate(self, quat, vel, lla, rates, dt_k):
        mat_nb = rotation.mat_from_quat(quat)
        omega_b, f_b = rates
        kernels.system_matrix26(lla[0], lla[2], vel, f_b, mat_nb, omega_b, self.F)
        if dt_k <= 0.0:
            return
        kernels.noise26(mat_nb, *self.noise, self.Qc)
        kernels.discretize(self.F, self.Qc, dt_k, self.Phi, self.Qd)
        kernels.predict(self.x, self.P, self.Phi, self.Qd)

    def update(self, gnss, quat, vel, lla, omega_b):
        """Measurement update at the stored PPS state; returns the per-row arrays."""
        cfg, n = self.cfg, self.n
        quat, vel, lla = correct(quat, vel, lla, self.x)
        mat_nb = rotation.mat_from_quat(quat)
        omega_eb_b = omega_b - mat_nb.T @ earth.rate_ie_n(lla[0])
        r_ant, v_ant = antenna(lla, vel, mat_nb, omega_eb_b, cfg.lever_arm)
        k = len(gnss)
        H = np.zeros((2 * k, n))
        zhat = np.empty(2 * k)
        j_v = np.empty((3, 3))
        kernels.earth_jacobians(lla[0], lla[2], vel, j_v, np.empty((3, 3)), np.empty((3, 3)),
                                np.empty((3, 3)))
        mat_ne = earth.mat_en(lla[0], lla[1]).T
        lever_n = mat_nb @ cfg.lever_arm
        kernels.pseudorange_rows(r_ant, v_ant, mat_ne, j_v, lever_n,
                                 mat_nb @ np.cross(omega_eb_b, cfg.lever_arm),
                                 gnss.sat_pos, gnss.sat_vel, H, zhat)
        z = np.empty(2 * k)
        z[0::2] = gnss.pseudorange + gnss.sat_clock - gnss.delay
        z[1::2] = gnss.range_rate + gnss.sat_clock_drift
        if not self.clock_ready:  # receiver clock from the first epoch's residuals
            self.x[15] = np.median(z[0::2] - zhat[0::2])
            self.x[16] = np.median(z[1::2] - zhat[1::2])
            self.clock_ready = True
        y0 = z - zhat - np.repeat([[self.x[15], self.x[16]]], k, axis=0).ravel()
        r = np.empty(2 * k)
        r[0::2], r[1::2] = gnss.sigma_pr**2, gnss.sigma_rr**2
        rows = np.arange(2 * k) if cfg.use_range_rate else np.arange(0, 2 * k, 2)
        acc = np.zeros(rows.size, dtype=np.bool_)
        y_out, s_out = np.empty(rows.size), np.empty(rows.size)
        kernels.sequential_update(self.x, self.P, H[rows], y0[rows], r[rows], self.threshold,
                                  acc, y_out, s_out)
        return rows, acc, y_out, s_out

    def feedback(self, tau):
        """FB: apply the correction to the current state (carried over ``tau``), reset."""
        delta = self.x.copy()
        if tau > 0.0:
            delta = delta + tau * (self.F @ delta)
        quat, vel, lla = correct(self.nav.quat_nb, self.nav.vel_n, self.nav.lla, delta)
        self.nav = strapdown.NavState(quat, vel, lla, self.nav.dtheta_prev, self.nav.dv_prev,
                                      self.nav.count)
        self.cum_nav += self.x[_NAV]
        sens = _SENS[: self.n - 11] if self.n == 26 else np.r_[9:15]
        self.comp[: sens.size] += self.x[sens]
        self.x[_NAV] = 0.0
        self.x[sens] = 0.0


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
    """
    cfg, run = config, _Run(config, initial, t0)
    fb = cfg.coupling is Coupling.FB
    log = {k: [] for k in ("time", "quat", "vel", "lla", "state", "sigma", "cum", "err",
                           "nees", "heading_err", "n_sats", "n_used", "n_rejected", "coasted",
                           "nis", "update_s")}
    innov = {k: [] for k in ("epoch", "prn", "kind", "value", "variance", "accepted")}
    start_wall = _time.perf_counter()
    t_end = t0
    for index, ep in enumerate(epochs):
        dth, dv = (_compensate(ep.dtheta, ep.dv, cfg.dt, run.comp) if fb
                   else (ep.dtheta, ep.dv))
        start = run.nav
        end, series = strapdown.integrate(start, dth, dv, cfg.dt)
        t_k, tau = ep.gnss.time, ep.gnss.arrival - ep.gnss.time
        t_end = ep.gnss.arrival
        p = ep.pps_index if cfg.pps_storage else dth.shape[0]
        mid = max(p - int(round(0.5 * (t_k - run.t_prev) / cfg.dt)), 0)
        tick = _time.perf_counter()
        rates_mid = _mean_rates(dth, dv, mid, cfg.dither_window, cfg.dt, run.rates)
        run.propagate(*_state_at(start, series, mid), rates_mid, t_k - run.t_prev)
        quat, vel, lla = _state_at(start, series, p)
        run.rates = _mean_rates(dth, dv, p, cfg.dither_window, cfg.dt, run.rates)
        run.nav = end
        k = len(ep.gnss)
        coasted = k == 0 or cfg.in_outage(t_k)
        n_used = 0
        nis = 0.0
        if not coasted:
            rows, acc, y, s = run.update(ep.gnss, quat, vel, lla, run.rates[0])
            n_used = int(acc.sum())
            nis = float(np.sum(y[acc] ** 2 / s[acc]))
            innov["epoch"].append(np.full(rows.size, index))
            innov["prn"].append(ep.gnss.prn[rows // 2])
            innov["kind"].append(rows % 2)
            for key, value in (("value", y), ("variance", s), ("accepted", acc)):
                innov[key].append(value)
            log["n_rejected"].append(rows.size - n_used)
        else:
            log["n_rejected"].append(0)
        out = correct(quat, vel, lla, run.x)
        estimate = run.x.copy()
        sens = _SENS[: run.n - 11] if run.n == 26 else np.r_[9:15]
        estimate[sens] += run.comp[: sens.size]
        if ep.truth is not None and true_sensor is not None:
            e = _truth_error(ep.truth, out, estimate, true_sensor)
            log["err"].append(e[:9])
            log["nees"].append(float(kalman.nees(e, run.P)))
            true_heading = rotation.euler_from_mat(ep.truth.mat_nb)[2]
            log["heading_err"].append(float(rotation.wrap_angle(
                rotation.euler_from_mat(rotation.mat_from_quat(out[0]))[2] - true_heading)))
        log["sigma"].append(np.sqrt(np.diag(run.P)))
        if fb and not coasted:
            run.feedback(tau)
        log["update_s"].append(_time.perf_counter() - tick)
        run.t_prev = t_k
        for key, value in (("time", t_k), ("quat", out[0]), ("vel", out[1]), ("lla", out[2]),
                           ("state", estimate), ("n_sats", k), ("n_used", n_used),
                           ("coasted", coasted), ("nis", nis)):
            log[key].append(value)
        cum = np.zeros(run.n)
        cum[_NAV] = run.cum_nav
        cum[sens] = run.comp[: sens.size]
        log["cum"].append(cum)
    wall = _time.perf_counter() - start_wall
    return EkfResult.from_logs(cfg, log, innov, t_end - t0, wall)
