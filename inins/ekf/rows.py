"""Measurement rows of the filters, one small compiled function per kind, each returning
``(y, H, r)``: the innovation ``y = z - h(nav (-) x)`` (m,), its rows ``H = dz/dx``
(m, n) and the noise variances ``r`` (m,) (``R = diag(r)``: the rows are updated one
scalar at a time, :func:`inins.ekf.kernels.sequential_update`).

The states are errors, estimated minus true (spec §2), with the phi angle
``C_est = (I - [phi x]) C``; so the columns of the navigation states are minus the
sensitivity of ``h`` at the estimate, those of the sensor and clock states (values,
not errors) plus it. Columns are the named blocks of :mod:`inins.ekf.kernels`
(``POS``, ``VEL``, ``ATT``, ``BG``, ``CLK``) and a time-offset state ``td``.
Every block is derived in spec §6b and checked against a finite difference of
the nonlinear model in ``tests/ekf/test_jacobians.py``:

- :func:`pseudorange_rows`, :func:`range_rate_rows`: tightly coupled, per satellite
  (on the geometry of :func:`line_of_sight`)
  (003 eq. 7, spec §6a);
- :func:`antenna_position_rows`, :func:`antenna_velocity_rows`: loosely coupled, the
  GNSS solution of the antenna (spec §10);
- :func:`nhc_rows`, :func:`odometer_rows`, :func:`zupt_rows`, :func:`zaru_rows`: the
  vehicle aiding (:mod:`inins.ekf.aiding`).
"""

import math
from collections import namedtuple

import numpy as np

from inins.core import earth, jit
from inins.ekf import kernels
from inins.ekf.kernels import ATT, BA, BG, CLK, POS, VEL, mv3

Antenna = namedtuple("Antenna", "lla r_imu mat_en mat_nb vel lever_n lever_vel_n r v j_v")
"""The antenna of an INS state (:func:`inins.ekf.step.antenna`): the IMU's ``lla`` (3,)
and ECEF position ``r_imu`` (3,) m, ``mat_en`` NED to ECEF and ``mat_nb`` (3, 3), the
NED velocity ``vel`` (3,) m/s, the lever arm ``lever_n = C_nb l_b`` (3,) m and its velocity
``lever_vel_n = C_nb (omega_eb_b x l_b)`` (3,) m/s, the antenna's ECEF position ``r``
and velocity ``v`` (3,), and ``J_v`` (3, 3) (the NED frame turns by ``J_v dr``)."""
Satellites = namedtuple(
    "Satellites",
    "prn pos vel pseudorange clock delay range_rate clock_drift sigma_pr sigma_rr",
)
"""``k`` satellites' measurements (the fields of :class:`inins.ekf.measurements.GnssEpoch`):
``prn`` (k,) int, ECEF ``pos``, ``vel`` (k, 3), and per satellite (k,) the pseudorange
(m), satellite clock (m), modelled delay (m), range rate (m/s), satellite clock drift
(m/s), and the pseudorange and range-rate 1-sigma (m, m/s)."""


@jit.njit(cache=True, error_model="numpy")
def earth_rate_n(lat):
    """``w_ie`` (3,) rad/s in NED at latitude ``lat``."""
    w = earth.RATE
    return np.array([w * math.cos(lat), 0.0, -w * math.sin(lat)])


@jit.njit(cache=True, error_model="numpy")
def _skew(a):
    """``[a x]`` (3, 3)."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


@jit.njit(cache=True, error_model="numpy")
def skew_block(H, row, col, a, sign):
    """``H[row:row+3, col:col+3] = sign [a x]``."""
    H[row, col + 1] = -sign * a[2]
    H[row, col + 2] = sign * a[1]
    H[row + 1, col] = sign * a[2]
    H[row + 1, col + 2] = -sign * a[0]
    H[row + 2, col] = -sign * a[1]
    H[row + 2, col + 1] = sign * a[0]


@jit.njit(cache=True, error_model="numpy")
def line_of_sight(ant, sats):
    """Range ``rho`` (k,) m and unit line of sight ``e`` (k, 3) NED from the antenna to
    each satellite (the geometry both the pseudorange and the range-rate rows use)."""
    k = sats.pos.shape[0]
    rho, e = np.empty(k), np.empty((k, 3))
    m, r = ant.mat_en, ant.r  # e_n = C_ne (d / rho), C_ne = C_en^T
    for i in range(k):
        d0, d1, d2 = sats.pos[i, 0] - r[0], sats.pos[i, 1] - r[1], sats.pos[i, 2] - r[2]
        rh = math.sqrt(d0**2 + d1**2 + d2**2)
        u0, u1, u2 = d0 / rh, d1 / rh, d2 / rh
        e[i, 0] = m[0, 0] * u0 + m[1, 0] * u1 + m[2, 0] * u2
        e[i, 1] = m[0, 1] * u0 + m[1, 1] * u1 + m[2, 1] * u2
        e[i, 2] = m[0, 2] * u0 + m[1, 2] * u1 + m[2, 2] * u2
        rho[i] = rh
    return rho, e


@jit.njit(cache=True, error_model="numpy")
def pseudorange_rows(ant, sats, los, x, bias_col):
    """Pseudoranges ``rho = |r_sat - r_ant| + c dt + b_s - c dt_sat + T + I`` (spec
    §6a), one row per satellite; ``los`` the :func:`line_of_sight` of ``ant``.

    With ``e`` the unit line of sight (NED) and ``dr_ant = dr + [l_n x] phi``
    (spec §6b) the sensitivities at the estimate are ``-e^T`` on position and
    ``-e^T [l_n x]`` on attitude; the error columns are their negatives, ``e^T`` and
    ``e^T [l_n x] = (e x l_n)^T``; 1 on the clock bias and on the satellite's
    inter-system bias state ``bias_col[i]`` (-1: none).
    """
    rho, e = los
    k, n = rho.shape[0], x.shape[0]
    H, y, r = np.zeros((k, n)), np.empty(k), np.empty(k)
    l0, l1, l2 = ant.lever_n[0], ant.lever_n[1], ant.lever_n[2]
    for i in range(k):
        e0, e1, e2 = e[i, 0], e[i, 1], e[i, 2]
        h = H[i]
        h[POS], h[POS + 1], h[POS + 2] = e0, e1, e2
        # -e^T [l x] = l x e
        h[ATT] = -(l1 * e2 - l2 * e1)
        h[ATT + 1] = -(l2 * e0 - l0 * e2)
        h[ATT + 2] = -(l0 * e1 - l1 * e0)
        h[CLK] = 1.0
        y[i] = sats.pseudorange[i] + sats.clock[i] - sats.delay[i] - rho[i] - x[CLK]
        if bias_col[i] >= 0:
            h[bias_col[i]] = 1.0
            y[i] -= x[bias_col[i]]
        r[i] = sats.sigma_pr[i] ** 2
    return y, H, r


@jit.njit(cache=True, error_model="numpy")
def range_rate_rows(ant, sats, los, x):
    """Range rates ``rhodot = (v_sat - v_ant) . e + c dt' - c dt_sat'`` (spec §6a),
    one row per satellite; ``los`` the :func:`line_of_sight` of ``ant``.

    With ``dv = v_sat - v_ant`` (NED), ``rho`` the range, ``u_n`` the lever arm's
    velocity and ``G = -dv^T (I - e e^T) / rho``, the sensitivities at the estimate are
    ``e^T [v_ant x] J_v + G`` on position, ``-e^T`` on velocity, ``-e^T [u_n x] + G [l_n x]``
    on attitude (from ``dv_ant = dv - [v_ant x] J_v dr + [u_n x] phi``: the estimated NED
    frame is turned by ``J_v dr``); the error columns are their negatives, and 1 on the
    clock drift. The lever arm's velocity is formed with the Earth rate turned into body
    axes by the estimated attitude and the gyro-bias state removed (``omega_eb =
    omega_ib - bg - C_bn w_ie``), which adds ``-e^T [l_n x][w_ie x]`` to the attitude
    columns and ``-e^T C_nb [l_b x]`` on ``BG`` (spec §6b).
    """
    rho, e = los
    k, n = rho.shape[0], x.shape[0]
    H, y, r = np.zeros((k, n)), np.empty(k), np.empty(k)
    m, c, j_v = ant.mat_en, ant.mat_nb, ant.j_v
    va = mv3(m.T, ant.v)  # the antenna velocity (NED), the same for every satellite
    l0, l1, l2 = ant.lever_n[0], ant.lever_n[1], ant.lever_n[2]
    u0, u1, u2 = ant.lever_vel_n[0], ant.lever_vel_n[1], ant.lever_vel_n[2]
    w = earth_rate_n(ant.lla[0])
    lw = l0 * w[0] + l1 * w[1] + l2 * w[2]
    for i in range(k):
        # dv = C_ne (v_sat - v_ant)
        s0, s1, s2 = sats.vel[i, 0] - ant.v[0], sats.vel[i, 1] - ant.v[1], sats.vel[i, 2] - ant.v[2]
        dv0 = m[0, 0] * s0 + m[1, 0] * s1 + m[2, 0] * s2
        dv1 = m[0, 1] * s0 + m[1, 1] * s1 + m[2, 1] * s2
        dv2 = m[0, 2] * s0 + m[1, 2] * s1 + m[2, 2] * s2
        e0, e1, e2 = e[i, 0], e[i, 1], e[i, 2]
        edv = dv0 * e0 + dv1 * e1 + dv2 * e2
        g0 = -(dv0 - edv * e0) / rho[i]
        g1 = -(dv1 - edv * e1) / rho[i]
        g2 = -(dv2 - edv * e2) / rho[i]
        # a^T [b x] phi = a . (b x phi) = (a x b) . phi: the row of a^T [b x] is a x b;
        # e^T [v x] J_v = (e x v)^T J_v
        x0, x1, x2 = e1 * va[2] - e2 * va[1], e2 * va[0] - e0 * va[2], e0 * va[1] - e1 * va[0]
        h = H[i]
        h[POS] = -(j_v[0, 0] * x0 + j_v[1, 0] * x1 + j_v[2, 0] * x2) - g0
        h[POS + 1] = -(j_v[0, 1] * x0 + j_v[1, 1] * x1 + j_v[2, 1] * x2) - g1
        h[POS + 2] = -(j_v[0, 2] * x0 + j_v[1, 2] * x1 + j_v[2, 2] * x2) - g2
        h[VEL], h[VEL + 1], h[VEL + 2] = e0, e1, e2
        # -e^T [u x] + G [l x] = u x e + g x l; the lever arm's Earth rate turns with
        # the attitude: -e^T [l x][w x] = (l . w) e^T - (e . w) l^T
        ew = e0 * w[0] + e1 * w[1] + e2 * w[2]
        h[ATT] = -((u1 * e2 - u2 * e1) + (g1 * l2 - g2 * l1)) + (lw * e0 - ew * l0)
        h[ATT + 1] = -((u2 * e0 - u0 * e2) + (g2 * l0 - g0 * l2)) + (lw * e1 - ew * l1)
        h[ATT + 2] = -((u0 * e1 - u1 * e0) + (g0 * l1 - g1 * l0)) + (lw * e2 - ew * l2)
        # the gyro bias leaves the lever arm's rate: -e^T C_nb [l_b x] = (C_bn (l_n x e))^T
        c0, c1, c2 = l1 * e2 - l2 * e1, l2 * e0 - l0 * e2, l0 * e1 - l1 * e0
        h[BG] = c[0, 0] * c0 + c[1, 0] * c1 + c[2, 0] * c2
        h[BG + 1] = c[0, 1] * c0 + c[1, 1] * c1 + c[2, 1] * c2
        h[BG + 2] = c[0, 2] * c0 + c[1, 2] * c1 + c[2, 2] * c2
        h[CLK + 1] = 1.0
        y[i] = sats.range_rate[i] + sats.clock_drift[i] - edv - x[CLK + 1]
        r[i] = sats.sigma_rr[i] ** 2
    return y, H, r


@jit.njit(cache=True, error_model="numpy")
def antenna_position_rows(ant, pos_e, var, x, td, lag):
    """The GNSS solution's antenna position ``pos_e`` (3,) ECEF m, variances ``var`` (3,)
    m^2 NED, taken ``lag`` s after the INS state (spec §10, §6b).

    Predicted ``r_ant = r + C_nb l_b + v lag`` (the antenna carried over the lag by the
    INS velocity, taken as known: the velocity error's share ``lag dv`` is not modelled,
    spec §6b); in NED at the INS position ``y = z - r_ant``, ``H``: ``-I`` on
    ``POS``, ``-[l_n x]`` on ``ATT`` and ``+v`` on the time-offset state ``td`` (-1: none;
    ``lag`` includes its estimate).
    """
    n = x.shape[0]
    H = np.zeros((3, n))
    r_ant = ant.r_imu + mv3(ant.mat_en, ant.lever_n + ant.vel * lag)
    y = mv3(ant.mat_en.T, pos_e - r_ant)
    for i in range(3):
        H[i, POS + i] = -1.0
        if td >= 0:
            H[i, td] = ant.vel[i]
    skew_block(H, 0, ATT, ant.lever_n, -1.0)
    return y, H, var.copy()


@jit.njit(cache=True, error_model="numpy")
def antenna_velocity_rows(ant, vel_n, var, f_n, x, td, lag):
    """The GNSS solution's antenna velocity ``vel_n`` (3,) NED m/s, variances ``var`` (3,),
    taken ``lag`` s after the INS state (spec §10, §6b).

    Predicted ``v_ant = v + C_nb (omega_eb x l_b) + a lag`` with the INS acceleration
    ``a = f_n + g``, ``f_n = C_nb (f_b - ba)`` the specific force (3,) (Coriolis dropped);
    ``H``: ``-I`` on ``VEL``, ``-[u_n x] + [l_n x][w_ie x] - lag [f_n x]`` on ``ATT``
    (``u_n = C_nb (omega_eb x l_b)``, ``omega_eb = omega_ib - bg - C_bn w_ie``),
    ``-lag C_nb`` on ``BA``, ``[l_n x] C_nb`` on ``BG``, ``+a`` on ``td``.
    """
    n = x.shape[0]
    H, y = np.zeros((3, n)), np.empty(3)
    acc = f_n.copy()
    acc[2] += kernels._gravity(ant.lla[0], ant.lla[2])
    for i in range(3):
        H[i, VEL + i] = -1.0
        y[i] = vel_n[i] - ant.vel[i] - ant.lever_vel_n[i] - acc[i] * lag
        if td >= 0:
            H[i, td] = acc[i]
    skew_block(H, 0, ATT, ant.lever_vel_n, -1.0)
    lever_x = _skew(ant.lever_n)
    H[:, ATT : ATT + 3] += lever_x @ _skew(earth_rate_n(ant.lla[0])) - lag * _skew(f_n)
    H[:, BA : BA + 3] = -lag * ant.mat_nb
    H[:, BG : BG + 3] = lever_x @ ant.mat_nb
    return y, H, var.copy()


@jit.njit(cache=True, error_model="numpy")
def _vehicle_velocity(c_vn, vel, axes, n):
    """Rows ``axes`` of ``v_v = C_vn v`` (spec §6b): ``-C_vn`` on ``VEL``,
    ``+C_vn [v x]`` on ``ATT``; returns (predicted, H)."""
    vx = np.zeros((3, 3))
    vx[0, 1], vx[0, 2], vx[1, 0] = -vel[2], vel[1], vel[2]
    vx[1, 2], vx[2, 0], vx[2, 1] = -vel[0], -vel[1], vel[0]
    mv = c_vn @ vx
    vv = c_vn @ vel
    m = len(axes)
    H, pred = np.zeros((m, n)), np.empty(m)
    for k in range(m):
        i = axes[k]
        for j in range(3):
            H[k, VEL + j] = -c_vn[i, j]
            H[k, ATT + j] = mv[i, j]
        pred[k] = vv[i]
    return pred, H


@jit.njit(cache=True, error_model="numpy")
def nhc_rows(c_vn, vel, sigma, n):
    """Non-holonomic constraint: the lateral and vertical vehicle velocity
    ``(C_vb C_bn v)_{y,z}`` are zero, 1-sigma ``sigma`` m/s (spec §10, §6b);
    ``c_vn = C_vb C_bn`` (3, 3), ``vel`` the INS velocity (3,) NED."""
    pred, H = _vehicle_velocity(c_vn, vel, (1, 2), n)
    return -pred, H, np.full(2, sigma**2)


@jit.njit(cache=True, error_model="numpy")
def odometer_rows(c_vn, vel, speed, sigma, n):
    """Odometer: the forward vehicle speed ``(C_vb C_bn v)_x`` is ``speed`` m/s, 1-sigma
    ``sigma`` (spec §10, §6b)."""
    pred, H = _vehicle_velocity(c_vn, vel, (0,), n)
    return speed - pred, H, np.full(1, sigma**2)


@jit.njit(cache=True, error_model="numpy")
def zupt_rows(vel, sigma, n):
    """Zero velocity: ``v_true = 0``; ``y = -v``, ``-I`` on ``VEL``, 1-sigma ``sigma`` m/s."""
    H, y = np.zeros((3, n)), np.empty(3)
    for i in range(3):
        H[i, VEL + i] = -1.0
        y[i] = -vel[i]
    return y, H, np.full(3, sigma**2)


@jit.njit(cache=True, error_model="numpy")
def zaru_rows(omega_mean, c_bn, w_ie_n, x, sigma):
    """Zero angular rate: the compensated gyro mean ``omega_mean`` (3,) rad/s is the
    Earth rate in body axes plus the residual gyro bias, ``C_bn w_ie + bg``:
    ``y = omega_mean - C_bn w_ie - bg``; ``H``: ``+I`` on ``BG``, ``C_bn [w_ie x]`` on
    ``ATT`` (the estimated attitude turns the Earth rate); 1-sigma ``sigma`` rad/s."""
    n = x.shape[0]
    H, y = np.zeros((3, n)), np.empty(3)
    z = omega_mean - c_bn @ w_ie_n
    H[:, ATT : ATT + 3] = c_bn @ _skew(w_ie_n)
    for i in range(3):
        H[i, BG + i] = 1.0
        y[i] = z[i] - x[BG + i]
    return y, H, np.full(3, sigma**2)
