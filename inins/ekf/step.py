"""One filter epoch in compiled code: propagation, update at the 1PPS state, FB feedback.

:func:`epoch` is the whole epoch of :func:`inins.ekf.filter.run_filter` with
preallocated arrays: :func:`compensate` (FB), the strapdown, :func:`mean_rates_at` /
:func:`mean_rates`, :func:`propagate` (once, or once per sub-interval when the rates
change fast), :func:`update`, :func:`correct`, (FB) :func:`feedback`, and the
epoch's log; :func:`epochs` runs it over a batch of epochs in one call. The building
blocks stay separate kernels (tested on their own, and the loosely coupled filter
uses some); an epoch of EKF2 with nine satellites costs about 33 us, a third of it
the strapdown's 200 samples. The equations are those of :mod:`inins.ekf.filter`
(module docstring) and :mod:`inins.ekf.kernels`; the navigation helpers here are the scalar forms of
:func:`inins.core.earth.mat_en`, :func:`~inins.core.earth.ecef_from_llh`,
:func:`inins.core.rotation.mat_from_quat` and :func:`inins.ekf.measurements.antenna`
(tested equal in ``tests/ekf/test_step.py``).
"""

import math

import numpy as np

from inins.core import earth, jit, strapdown
from inins.ekf import kernels

_radii = jit.njit(cache=True)(earth.principal_radii)


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
def update(
    x,
    P,
    quat,
    vel,
    lla,
    omega_b,
    lever_b,
    sat_pos,
    sat_vel,
    pseudorange,
    sat_clock,
    delay,
    range_rate,
    sat_clock_drift,
    sigma_pr,
    sigma_rr,
    bias_col,
    threshold,
    use_rr,
    init_clock,
    acc,
    y,
    s,
):
    """Measurement update at the PPS state (``k`` satellites, ``n`` states).

    Per satellite (k,): pseudorange (m), satellite clock (m), delay (m), range rate
    (m/s), satellite clock drift (m/s), pseudorange and range-rate 1-sigma (m, m/s),
    and ``bias_col`` (int) the state of its system's inter-system bias, or -1 (the
    reference system: the receiver clock alone). A pseudorange row has 1 at the clock
    bias and 1 at its ``bias_col`` (the bias is common to code, not to range rate).
    ``sat_pos``, ``sat_vel`` (k, 3) ECEF; ``x`` (n,), ``P`` (n, n) updated in place.
    The rows are pseudorange, range rate per satellite (range rates skipped unless
    ``use_rr``): ``acc``, ``y``, ``s`` hold, per row used (2 k or k), the gate's
    verdict, the innovation and its variance. ``init_clock``: the clock states are
    first set to the median residuals (the bias from the reference system's rows, or
    all rows without one; each inter-system bias to its rows' median minus that).
    Returns the number of accepted rows.
    """
    n, k = x.shape[0], sat_pos.shape[0]
    cq, cv, cl = np.empty(4), np.empty(3), np.empty(3)
    correct(quat, vel, lla, x, cq, cv, cl)
    mat_nb = mat_from_quat(cq)
    w = earth.RATE
    w_ie = np.array([w * math.cos(cl[0]), 0.0, -w * math.sin(cl[0])])
    omega_eb = omega_b - kernels.mv3(mat_nb.T, w_ie)
    m_en = mat_en(cl[0], cl[1])
    lever_n = kernels.mv3(mat_nb, lever_b)
    lever_vel = kernels.mv3(mat_nb, np.cross(omega_eb, lever_b))
    r_ant = ecef(cl) + kernels.mv3(m_en, lever_n)
    v_ant = kernels.mv3(m_en, cv + lever_vel)
    j_v = np.empty((3, 3))
    kernels.earth_jacobians(
        cl[0], cl[2], cv, j_v, np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
    )
    H = np.zeros((2 * k, n))
    zhat = np.empty(2 * k)
    kernels.pseudorange_rows(
        r_ant, v_ant, m_en.T, j_v, lever_n, lever_vel, sat_pos, sat_vel, H, zhat
    )
    z = np.empty(2 * k)
    r = np.empty(2 * k)
    for i in range(k):
        z[2 * i] = pseudorange[i] + sat_clock[i] - delay[i]
        z[2 * i + 1] = range_rate[i] + sat_clock_drift[i]
        r[2 * i] = sigma_pr[i] ** 2
        r[2 * i + 1] = sigma_rr[i] ** 2
    for i in range(k):
        if bias_col[i] >= 0:
            H[2 * i, bias_col[i]] = 1.0
    if init_clock:  # receiver clock from the first epoch's residuals
        res = z[0::2] - zhat[0::2]
        ref = bias_col < 0
        x[kernels.CLK] = np.median(res[ref]) if ref.any() else np.median(res)
        x[kernels.CLK + 1] = np.median(z[1::2] - zhat[1::2])
        for c in range(kernels.CLK + 2, n):
            own = bias_col == c
            if own.any():
                x[c] = np.median(res[own]) - x[kernels.CLK]
    step = 1 if use_rr else 2
    m = (2 * k + step - 1) // step
    y0, Hs, rs = np.empty(m), np.empty((m, n)), np.empty(m)
    for j in range(m):
        i = j * step
        y0[j] = z[i] - zhat[i] - x[kernels.CLK + i % 2]
        if i % 2 == 0 and bias_col[i // 2] >= 0:
            y0[j] -= x[bias_col[i // 2]]
        Hs[j] = H[i]
        rs[j] = r[i]
    return kernels.sequential_update(x, P, Hs, y0, rs, threshold, acc, y, s)


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
    for i in range(9):
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


# The fused epoch (:func:`epoch`): slots of its matrix work array and columns of its logs.
F_, QC, PHI, QD, P_PRED, PHI_K, P_UPD = range(7)
"""Slots of ``mats`` (7, n, n): the model, its noise, transition and discrete noise of
the last (sub-)interval, then what a smoother's store keeps: ``P`` predicted, the
interval's ``Phi_k`` (the product over sub-intervals) and ``P`` updated."""
LOG_TIME, LOG_GNSS_TIME, LOG_NIS, LOG_QUAT, LOG_VEL, LOG_LLA, LOG_STATE = 0, 1, 2, 3, 7, 10, 13
"""Columns of an epoch's row of ``flog`` (13 + 3 n): the time the state refers to, the
PPS, the NIS sum, the output quaternion, velocity, position, then the state estimate
(sensor totals), its 1-sigma and the cumulative corrections (``n`` each)."""
N_SATS, N_USED, N_REJECTED, COASTED = 0, 1, 2, 3
"""Columns of an epoch's row of ``ilog`` (4, int)."""
T_STATE, T_K, DT_K, TAU = 0, 1, 2, 3
"""Columns of a batch's ``times`` (:func:`epochs`): the arguments of :func:`epoch`."""
PPS_INDEX, IS_COASTED, INIT_CLOCK, KEEP_COV = 0, 1, 2, 3
"""Columns of a batch's ``flags`` (:func:`epochs`): ``p``, ``coasted``, ``init_clock``,
``keep_cov`` of :func:`epoch` (0 or 1 but the first)."""


@jit.njit(cache=True, error_model="numpy")
def _state_at(start_q, start_v, start_l, out_q, out_v, out_l, index):
    """(quat, vel, lla) after ``index`` samples of a chunk (0: the chunk start)."""
    if index == 0:
        return start_q, start_v, start_l
    return out_q[index - 1], out_v[index - 1], out_l[index - 1]


@jit.njit(cache=True, error_model="numpy")
def epoch(
    x,
    P,
    mats,
    quat,
    vel,
    lla,
    prev,
    count,
    home,
    comp,
    cum,
    sens,
    rates,
    rates_sub,
    dt,
    window,
    noise,
    lever,
    limits,
    threshold,
    use_rr,
    fb,
    keep,
    dtheta,
    dv,
    p,
    dt_k,
    tau,
    coasted,
    init_clock,
    t_state,
    t_k,
    prn,
    sat_pos,
    sat_vel,
    pseudorange,
    sat_clock,
    delay,
    range_rate,
    sat_clock_drift,
    sigma_pr,
    sigma_rr,
    bias_columns,
    index,
    flog,
    ilog,
    keep_cov,
    cov,
    inn_start,
    inn_f,
    inn_i,
    kept,
):
    """One filter epoch (:mod:`inins.ekf.filter`, module docstring, steps 1-4) in place.

    The building blocks in the order :func:`inins.ekf.filter.run_filter` used to call
    them from Python: (FB) :func:`compensate`, the strapdown
    (:func:`inins.core.strapdown._navigate`, free mode, coning and sculling, every
    sample), :func:`mean_rates_at` and :func:`rates_change` at the sub-interval
    middles, :func:`propagate` once or per sub-interval, :func:`mean_rates` at the
    PPS, :func:`update` (unless ``coasted``), :func:`correct` for the output, (FB)
    :func:`feedback`.

    State, updated in place: ``x`` (n,), ``P`` (n, n), ``mats`` (7, n, n) (slots
    :data:`F_` ...), the INS ``quat``, ``vel``, ``lla``, ``prev`` (6,) after ``count``
    samples, the FB compensation ``comp`` (15,) and cumulative navigation corrections
    ``cum`` (9,), ``sens`` the sensor states in ``comp`` order, the dither-filtered
    rates ``rates`` (2, 3) and ``rates_sub`` (j + 1, 2, 3) of the ``j`` sub-intervals.
    Settings: IMU interval ``dt`` (s), dither ``window`` (samples), ``noise`` of
    :func:`propagate`, ``lever`` (3,) m, ``limits`` of :func:`rates_change`, the
    gate ``threshold``, ``use_rr``, ``fb``, ``keep`` (fill the store slots of
    ``mats`` and ``kept``: a smoother's store). Epoch: increments ``dtheta``, ``dv``
    (s, 3) up to the data arrival, ``p`` samples to the state the update uses,
    interval ``dt_k`` (s) to it, FB latency ``tau`` (s), ``coasted``,
    ``init_clock`` (the first update sets the clock), the logged times ``t_state``,
    ``t_k`` (s), the measurements of :func:`update` and their ``prn``;
    ``bias_columns`` the inter-system bias state of each system
    (:meth:`inins.ekf.config.FilterConfig.bias_columns`: -1 the reference, -2 a system
    the filter does not take).

    Logs: row ``index`` of ``flog`` (columns :data:`LOG_TIME` ...) and ``ilog``
    (:data:`N_SATS` ...), ``cov[index]`` = ``P`` if ``keep_cov``; the innovation rows
    from ``inn_start`` on: ``inn_f`` (value, variance), ``inn_i`` (epoch, prn, kind
    0 pseudorange / 1 range rate, accepted). ``kept`` (n + 25,): with ``keep``, the
    updated ``x``, the INS (quat, vel, lla) at the update and the compensation after
    the reset. Returns the number of innovation rows written, or -1 (nothing updated
    or logged) if a satellite is of a system the filter does not take.
    """
    n = x.shape[0]
    F, Qc, Phi, Qd = mats[F_], mats[QC], mats[PHI], mats[QD]
    # 1. strapdown over the chunk (FB: compensated increments)
    if fb:
        dth, dvc = compensate(dtheta, dv, dt, comp)
    else:
        dth, dvc = dtheta, dv
    samples = dth.shape[0]
    q0, v0, l0 = quat.copy(), vel.copy(), lla.copy()
    out_q, out_v, out_l = np.empty((samples, 4)), np.empty((samples, 3)), np.empty((samples, 3))
    strapdown._navigate(
        quat,
        vel,
        lla,
        prev,
        count,
        dth,
        dvc,
        dt,
        0,  # free navigation
        True,
        True,
        1,
        home,
        np.empty(samples, np.int64),
        out_q,
        out_v,
        out_l,
    )
    # 2. propagation over dt_k, split when the rates change fast within it
    sub = rates_sub.shape[0] - 1
    span = round(dt_k / dt)
    probes = np.empty(sub + 1, np.int64)  # sub-interval middles, then the interval's
    for j in range(sub):
        probes[j] = max(p - (span - (2 * j + 1) * span // (2 * sub)), 0)
    probes[sub] = max(p - round(0.5 * dt_k / dt), 0)
    mean_rates_at(dth, dvc, probes, window, dt, rates_sub)
    split = dt_k > 0.0 and rates_change(rates_sub, limits)
    if not split:
        q, v, l = _state_at(q0, v0, l0, out_q, out_v, out_l, probes[sub])
        propagate(x, P, F, Qc, Phi, Qd, q, v, l, rates_sub[sub, 0], rates_sub[sub, 1], dt_k, noise)
        if keep:
            mats[PHI_K] = Phi
    else:
        total = mats[PHI_K]
        if keep:
            total[:] = np.eye(n)
        for j in range(sub):
            if keep and j:
                total[:] = Phi @ total
            q, v, l = _state_at(q0, v0, l0, out_q, out_v, out_l, probes[j])
            propagate(
                x, P, F, Qc, Phi, Qd, q, v, l, rates_sub[j, 0], rates_sub[j, 1], dt_k / sub, noise
            )
        if keep:
            total[:] = Phi @ total
    if keep:
        mats[P_PRED] = P
    # 3. update at the stored state
    q, v, l = _state_at(q0, v0, l0, out_q, out_v, out_l, p)
    mean_rates(dth, dvc, p, window, dt, rates)
    k = sat_pos.shape[0]
    flag = ilog[index]
    flag[N_SATS], flag[N_USED], flag[N_REJECTED], flag[COASTED] = k, 0, 0, coasted
    row = flog[index]
    row[LOG_NIS] = 0.0
    rows = 0
    if not coasted:
        bias_col = np.empty(k, np.int64)
        for i in range(k):
            system = prn[i] // 100  # inins.ekf.measurements.GnssEpoch.system
            column = bias_columns[system] if 0 <= system < bias_columns.size else -2
            if column < -1:
                return -1
            bias_col[i] = column
        rows = 2 * k if use_rr else k
        acc = np.zeros(rows, dtype=np.bool_)
        y, s = np.empty(rows), np.empty(rows)
        update(
            x,
            P,
            q,
            v,
            l,
            rates[0],
            lever,
            sat_pos,
            sat_vel,
            pseudorange,
            sat_clock,
            delay,
            range_rate,
            sat_clock_drift,
            sigma_pr,
            sigma_rr,
            bias_col,
            threshold,
            use_rr,
            init_clock,
            acc,
            y,
            s,
        )
        used = 0
        for j in range(rows):
            i = j if use_rr else 2 * j  # row 2 i pseudorange, 2 i + 1 range rate
            inn_f[inn_start + j, 0], inn_f[inn_start + j, 1] = y[j], s[j]
            out = inn_i[inn_start + j]
            out[0], out[1], out[2], out[3] = index, prn[i // 2], i % 2, acc[j]
            used += acc[j]
        flag[N_USED], flag[N_REJECTED] = used, rows - used
        row[LOG_NIS] = np.dot(y * y / s, acc.astype(np.float64))
    # the output: nav (-) x, the estimate (sensor totals), its sigma
    out_quat, out_vel, out_lla = np.empty(4), np.empty(3), np.empty(3)
    correct(q, v, l, x, out_quat, out_vel, out_lla)
    row[LOG_TIME], row[LOG_GNSS_TIME] = t_state, t_k
    row[LOG_QUAT : LOG_QUAT + 4] = out_quat
    row[LOG_VEL : LOG_VEL + 3] = out_vel
    row[LOG_LLA : LOG_LLA + 3] = out_lla
    estimate = x.copy()
    for j in range(sens.size):
        estimate[sens[j]] += comp[j]
    row[LOG_STATE : LOG_STATE + n] = estimate
    for i in range(n):
        row[LOG_STATE + n + i] = np.sqrt(P[i, i])
    if keep_cov:
        cov[index] = P
    if keep:
        mats[P_UPD] = P
        kept[:n] = x
        kept[n : n + 4], kept[n + 4 : n + 7], kept[n + 7 : n + 10] = q, v, l
        after = kept[n + 10 : n + 25]
        after[:] = comp
        if fb and not coasted:
            for j in range(sens.size):
                after[j] += x[sens[j]]
    # 4. FB: the correction carried over the latency to the current state, reset
    if fb and not coasted:
        feedback(x, F, tau, quat, vel, lla, comp, cum, sens)
    cumulative = row[LOG_STATE + 2 * n : LOG_STATE + 3 * n]
    cumulative[:] = 0.0
    cumulative[:9] = cum
    for j in range(sens.size):
        cumulative[sens[j]] = comp[j]
    return rows


@jit.njit(cache=True, error_model="numpy")
def epochs(
    x,
    P,
    mats,
    quat,
    vel,
    lla,
    prev,
    count,
    home,
    comp,
    cum,
    sens,
    rates,
    rates_sub,
    dt,
    window,
    noise,
    lever,
    limits,
    threshold,
    use_rr,
    fb,
    keep,
    dtheta,
    dv,
    starts,
    times,
    flags,
    prn,
    sat_pos,
    sat_vel,
    pseudorange,
    sat_clock,
    delay,
    range_rate,
    sat_clock_drift,
    sigma_pr,
    sigma_rr,
    sats,
    bias_columns,
    first,
    flog,
    ilog,
    cov,
    inn_start,
    inn_f,
    inn_i,
    kept,
):
    """:func:`epoch` for each of a batch of ``b`` epochs in turn: one call per batch, so
    that the cost of a call (its fifty arguments checked and converted, about 3 us) is
    paid once per batch, not once per epoch.

    The state and settings are those of :func:`epoch`, ``count`` the samples before the
    batch. The epochs' increments are concatenated in ``dtheta``, ``dv`` (epoch ``j``:
    rows ``starts[j]:starts[j + 1]``) and their satellites in ``prn`` ... ``sigma_rr``
    (rows ``sats[j]:sats[j + 1]``); ``times`` (b, 4) (columns :data:`T_STATE` ...) and
    ``flags`` (b, 4) (columns :data:`PPS_INDEX` ...) hold the rest of each epoch's
    arguments. Epoch ``j`` is logged in row ``first + j``, its innovation rows after
    those of the epochs before it, from ``inn_start`` on.

    Returns the number of innovation rows written, or ``-1 - j`` if epoch ``j`` has a
    satellite of a system the filter does not take (:func:`epoch` returns -1; the
    epochs after it are not run).
    """
    rows = 0
    for j in range(times.shape[0]):
        a, e, s0, s1 = starts[j], starts[j + 1], sats[j], sats[j + 1]
        written = epoch(
            x,
            P,
            mats,
            quat,
            vel,
            lla,
            prev,
            count + a,
            home,
            comp,
            cum,
            sens,
            rates,
            rates_sub,
            dt,
            window,
            noise,
            lever,
            limits,
            threshold,
            use_rr,
            fb,
            keep,
            dtheta[a:e],
            dv[a:e],
            flags[j, PPS_INDEX],
            times[j, DT_K],
            times[j, TAU],
            flags[j, IS_COASTED] != 0,
            flags[j, INIT_CLOCK] != 0,
            times[j, T_STATE],
            times[j, T_K],
            prn[s0:s1],
            sat_pos[s0:s1],
            sat_vel[s0:s1],
            pseudorange[s0:s1],
            sat_clock[s0:s1],
            delay[s0:s1],
            range_rate[s0:s1],
            sat_clock_drift[s0:s1],
            sigma_pr[s0:s1],
            sigma_rr[s0:s1],
            bias_columns,
            first + j,
            flog,
            ilog,
            flags[j, KEEP_COV] != 0,
            cov,
            inn_start + rows,
            inn_f,
            inn_i,
            kept,
        )
        if written < 0:
            return -1 - j
        rows += written
    return rows
