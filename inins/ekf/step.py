"""The compiled building blocks of a filter epoch: navigation helpers, propagation,
update at the 1PPS state, FB feedback.

The fused epoch of :func:`inins.ekf.filter.run_filter` (:func:`inins.ekf.fused.epoch`)
composes them: :func:`compensate` (FB), the strapdown, :func:`mean_rates_at` /
:func:`mean_rates`, :func:`propagate` (once, or once per sub-interval when the rates
change fast), :func:`update`, :func:`correct`, (FB) :func:`feedback`. The building
blocks stay separate kernels (tested on their own, and the loosely coupled filter uses some); an
epoch of EKF2 with nine satellites costs about 33 us, a third of it the strapdown's 200
samples. The equations are those of :mod:`inins.ekf.filter` (module docstring),
:mod:`inins.ekf.kernels` and the measurement rows of :mod:`inins.ekf.rows`; the
navigation helpers here are the scalar forms of :func:`inins.core.earth.mat_en`,
:func:`~inins.core.earth.ecef_from_llh`, :func:`inins.core.rotation.mat_from_quat` and
:func:`inins.ekf.measurements.antenna` (tested equal in ``tests/ekf/test_step.py``).

States are addressed by the named blocks of :mod:`inins.ekf.kernels`.
"""

import math
from collections import namedtuple

import numpy as np

from inins.core import earth, jit
from inins.ekf import kernels, rows
from inins.ekf.kernels import BG, CLK, NAV, mv3

_radii = jit.njit(cache=True)(earth.principal_radii)

Ins = namedtuple("Ins", "quat vel lla prev home")
"""The INS state, updated in place: ``quat`` (4,), ``vel`` (3,) m/s, ``lla`` (3,), the
previous increments ``prev`` (6,) (coning, sculling), and ``home`` (8,) the Earth terms of
the strapdown's fixed modes (unused: free navigation)."""


@jit.njit(cache=True, error_model="numpy")
def mat_from_quat(q):
    """``mat_nb`` (3, 3) of a unit quaternion ``[w, x, y, z]``."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


@jit.njit(cache=True, error_model="numpy")
def mat_en(lat, lon):
    """NED to ECEF (3, 3)."""
    sl, cl, so, co = math.sin(lat), math.cos(lat), math.sin(lon), math.cos(lon)
    return np.array([[-sl * co, -so, -cl * co], [-sl * so, co, -cl * so], [cl, 0.0, -sl]])


@jit.njit(cache=True, error_model="numpy")
def ecef(lla):
    """ECEF position (3,) m of ``[lat, lon, h]``."""
    _, re = _radii(lla[0])
    cl = math.cos(lla[0])
    return np.array(
        [
            (re + lla[2]) * cl * math.cos(lla[1]),
            (re + lla[2]) * cl * math.sin(lla[1]),
            (re * (1.0 - earth.E2) + lla[2]) * math.sin(lla[0]),
        ]
    )


@jit.njit(cache=True, error_model="numpy")
def correct(quat, vel, lla, dx, out_quat, out_vel, out_lla):
    """``nav (-) dx`` (first 9 states) into the ``out_`` arrays (may alias the inputs)."""
    rn, re = _radii(lla[0])
    lat = lla[0] - dx[0] / (rn + lla[2])
    lon = lla[1] - dx[1] / ((re + lla[2]) * math.cos(lla[0]))
    out_lla[2] = lla[2] + dx[2]
    out_lla[0], out_lla[1] = lat, lon
    for i in range(3):
        out_vel[i] = vel[i] - dx[3 + i]
    a2 = dx[6] ** 2 + dx[7] ** 2 + dx[8] ** 2
    a = math.sqrt(a2)
    c = math.cos(0.5 * a)
    k = 0.5 - a2 / 48.0 if a < 1e-4 else math.sin(0.5 * a) / a
    p0, p1, p2, p3 = c, k * dx[6], k * dx[7], k * dx[8]
    q0, q1, q2, q3 = quat[0], quat[1], quat[2], quat[3]
    r0 = p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3
    r1 = p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2
    r2 = p0 * q2 - p1 * q3 + p2 * q0 + p3 * q1
    r3 = p0 * q3 + p1 * q2 - p2 * q1 + p3 * q0
    norm = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2 + r3 * r3)
    out_quat[0], out_quat[1], out_quat[2], out_quat[3] = r0 / norm, r1 / norm, r2 / norm, r3 / norm


@jit.njit(cache=True, error_model="numpy")
def propagate(x, P, F, Qc, Phi, Qd, quat, vel, lla, omega_b, f_b, dt_k, noise):
    """Model at the mid-interval state, discretise, predict (``dt_k`` > 0).

    ``noise``: arw (3), vrw (3), accel and gyro bias walks (3 each), clock bias and drift
    densities, then one random-walk density (m^2/s) per inter-system bias state (the
    last ``noise.size - 14`` states).
    """
    mat_nb = mat_from_quat(quat)
    kernels.system_matrix26(lla[0], lla[2], vel, f_b, mat_nb, omega_b, F)
    if dt_k <= 0.0:
        return
    kernels.noise26(
        mat_nb, noise[0:3], noise[3:6], noise[6:9], noise[9:12], noise[12], noise[13], Qc
    )
    base = x.shape[0] - (noise.shape[0] - 14)
    for j in range(noise.shape[0] - 14):
        Qc[base + j, base + j] = noise[14 + j]
    kernels.discretize(F, Qc, dt_k, Phi, Qd)
    kernels.predict(x, P, Phi, Qd)


@jit.njit(cache=True, error_model="numpy")
def antenna(quat, vel, lla, dx, omega_b, lever_b):
    """The :data:`inins.ekf.rows.Antenna` of the INS state ``nav (-) dx`` with the body
    rate ``omega_b`` (3,) rad/s the INS integrates and the lever arm ``lever_b`` (3,) m
    (003 eqs. 8-9): ``r_ant = r + C_en C_nb l_b``, ``v_ant = C_en (v + C_nb (omega_eb_b x
    l_b))``, ``omega_eb_b = omega_b - bg - C_bn w_ie`` with ``bg`` the gyro-bias state."""
    cq, cv, cl = np.empty(4), np.empty(3), np.empty(3)
    correct(quat, vel, lla, dx, cq, cv, cl)
    mat_nb = mat_from_quat(cq)
    w = earth.RATE
    w_ie = np.array([w * math.cos(cl[0]), 0.0, -w * math.sin(cl[0])])
    omega_eb = omega_b - dx[BG : BG + 3] - mv3(mat_nb.T, w_ie)
    m_en = mat_en(cl[0], cl[1])
    lever_n = mv3(mat_nb, lever_b)
    lever_vel = mv3(mat_nb, np.cross(omega_eb, lever_b))
    r_imu = ecef(cl)
    j_v = np.empty((3, 3))
    kernels.earth_jacobians(
        cl[0], cl[2], cv, j_v, np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
    )
    return rows.Antenna(
        cl,
        r_imu,
        m_en,
        mat_nb,
        cv,
        lever_n,
        lever_vel,
        r_imu + mv3(m_en, lever_n),
        mv3(m_en, cv + lever_vel),
        j_v,
    )


@jit.njit(cache=True, error_model="numpy")
def initial_clock(x, y_pr, y_rr, bias_col):
    """Clock states from the first epoch's residuals (clock states zero): the bias the
    median pseudorange residual of the reference system's rows (all rows without one),
    the drift the median range-rate residual, each inter-system bias its rows' median
    minus the bias."""
    ref = bias_col < 0
    x[CLK] = np.median(y_pr[ref]) if ref.any() else np.median(y_pr)
    x[CLK + 1] = np.median(y_rr)
    for c in range(CLK + 2, x.shape[0]):
        own = bias_col == c
        if own.any():
            x[c] = np.median(y_pr[own]) - x[CLK]


@jit.njit(cache=True, error_model="numpy")
def update(x, P, nav, omega_b, model, sats, bias_col, init_clock, out):
    """Measurement update at the PPS state ``nav`` = (quat, vel, lla), ``k`` satellites.

    The rows (:func:`inins.ekf.rows.pseudorange_rows`, :func:`~inins.ekf.rows.range_rate_rows`)
    of the antenna of ``nav (-) x`` (:func:`antenna`, ``omega_b`` the dither-filtered
    body rate), pseudorange and range rate per satellite in turn (range rates left out
    unless ``model.use_rr``), each a gated scalar Joseph update; ``bias_col`` (k,) the
    inter-system bias state of each satellite or -1. ``init_clock``: the clock states are
    first set from the residuals (:func:`initial_clock`). ``x``, ``P`` updated in place;
    ``out`` = (accepted, innovation, variance) per row used (2 k or k). Returns the
    number of accepted rows.
    """
    quat, vel, lla = nav
    ant = antenna(quat, vel, lla, x, omega_b, model.lever)
    los = rows.line_of_sight(ant, sats)
    y_pr, H_pr, r_pr = rows.pseudorange_rows(ant, sats, los, x, bias_col)
    y_rr, H_rr, r_rr = rows.range_rate_rows(ant, sats, los, x)
    if init_clock:  # receiver clock from the first epoch's residuals
        initial_clock(x, y_pr, y_rr, bias_col)
        y_pr, H_pr, r_pr = rows.pseudorange_rows(ant, sats, los, x, bias_col)
        y_rr, H_rr, r_rr = rows.range_rate_rows(ant, sats, los, x)
    k, n = y_pr.shape[0], x.shape[0]
    step = 2 if model.use_rr else 1  # rows: pseudorange, range rate of each satellite
    y0, H, r = np.empty(step * k), np.empty((step * k, n)), np.empty(step * k)
    for i in range(k):
        y0[step * i] = y_pr[i]
        H[step * i] = H_pr[i]
        r[step * i] = r_pr[i]
        if model.use_rr:
            y0[2 * i + 1] = y_rr[i]
            H[2 * i + 1] = H_rr[i]
            r[2 * i + 1] = r_rr[i]
    acc, y, s = out
    return kernels.sequential_update(x, P, H, y0, r, model.threshold, acc, y, s)


@jit.njit(cache=True, error_model="numpy")
def mean_rates(dtheta, dv, centre, window, dt, out):
    """Moving average of ``omega_b``, ``f_b`` over ``window`` samples centred at ``centre``
    (003 §2.2), into ``out`` (2, 3); unchanged for an empty chunk."""
    n = dtheta.shape[0]
    if n == 0:
        return
    lo = min(max(centre - window // 2, 0), max(n - window, 0))
    hi = min(lo + window, n)
    out.fill(0.0)
    for k in range(lo, hi):
        for i in range(3):
            out[0, i] += dtheta[k, i]
            out[1, i] += dv[k, i]
    out /= (hi - lo) * dt


@jit.njit(cache=True, error_model="numpy")
def mean_rates_at(dtheta, dv, centres, window, dt, out):
    """:func:`mean_rates` at each of ``centres`` (j,) into ``out`` (j, 2, 3)."""
    for j in range(centres.shape[0]):
        mean_rates(dtheta, dv, centres[j], window, dt, out[j])


@jit.njit(cache=True, error_model="numpy")
def rates_change(rates, limits):
    """True if a row of ``rates`` (j, 2, 3) differs from the last one by more than
    ``limits[0]`` in ``omega_b`` (rad/s) or ``limits[1]`` in ``f_b`` (m/s^2), any axis."""
    last = rates.shape[0] - 1
    for j in range(last):
        for i in range(3):
            if abs(rates[j, 0, i] - rates[last, 0, i]) > limits[0]:
                return True
            if abs(rates[j, 1, i] - rates[last, 1, i]) > limits[1]:
                return True
    return False


@jit.njit(cache=True, error_model="numpy")
def feedback(x, F, tau, quat, vel, lla, comp, cum, sens):
    """FB: ``nav (-) (I + F tau) x`` in place, sensor estimates into ``comp``, states reset."""
    delta = x + tau * (F @ x)
    correct(quat, vel, lla, delta, quat, vel, lla)
    for i in range(NAV):
        cum[i] += x[i]
        x[i] = 0.0
    for j in range(sens.size):
        comp[j] += x[sens[j]]
        x[sens[j]] = 0.0


@jit.njit(cache=True, error_model="numpy")
def compensate(dtheta, dv, dt, comp):
    """Increments with the cumulative sensor estimates removed (new arrays).

    ``comp = [ba (3), bg (3), ma (3), mg (6)]``; ``omega = (I - M_g) (omega_meas - b_g)``,
    ``f = (I - M_a) (f_meas - b_a)`` with ``M`` the misalignment matrices of 003 eqs. 2-3.
    """
    n = dtheta.shape[0]
    out_t, out_v = np.empty((n, 3)), np.empty((n, 3))
    # (I - M_g) and (I - M_a) entry by entry, held in registers across the samples
    g01, g02, g10, g12, g20, g21 = -comp[9], -comp[10], -comp[11], -comp[12], -comp[13], -comp[14]
    a10, a20, a21 = -comp[6], -comp[7], -comp[8]
    b0, b1, b2 = comp[3] * dt, comp[4] * dt, comp[5] * dt
    a0, a1, a2 = comp[0] * dt, comp[1] * dt, comp[2] * dt
    for k in range(n):
        w0, w1, w2 = dtheta[k, 0] - b0, dtheta[k, 1] - b1, dtheta[k, 2] - b2
        f0, f1, f2 = dv[k, 0] - a0, dv[k, 1] - a1, dv[k, 2] - a2
        out_t[k, 0] = w0 + g01 * w1 + g02 * w2
        out_t[k, 1] = g10 * w0 + w1 + g12 * w2
        out_t[k, 2] = g20 * w0 + g21 * w1 + w2
        out_v[k, 0] = f0
        out_v[k, 1] = a10 * f0 + f1
        out_v[k, 2] = a20 * f0 + a21 * f1 + f2
    return out_t, out_v
