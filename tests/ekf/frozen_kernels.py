"""The filter numerics the fused epoch composes, frozen as they were before it.

Copies of the propagation and update kernels of :mod:`inins.ekf.step` and
:mod:`inins.ekf.kernels` (:func:`~inins.ekf.step.propagate`,
:func:`~inins.ekf.step.update` and everything they call: the error model, its
noise, the discretisation, the prediction, the pseudorange rows, the sequential
Joseph update, the navigation helpers) as of the commit before the fused epoch
kernel, compiled the same way: the reference arithmetic
``stepwise_filter.run_stepwise`` runs by default, so that a test of the filter
compares against the kernels as first written, not against themselves. The package
has since rewritten their arithmetic (the products over the rows the model moves, the
3 x 3 products written out), so the runs agree to rounding, not bit for bit; the
reference stays compiled, not numpy, so that the rounding compared is that of the
rewrite alone (numpy's own arithmetic differs in the last bits: ``dt**3`` is a
product of three in numba and one rounding in Python, and a pseudorange of 2e7 m
carries 4e-9 m of rounding, which the filter's feedback carries into its
corrections). Self-contained (only the Earth model's constants
and two of its functions come from the package), so that numba's on-disk cache of
these, stamped with this file only, never mixes in an edited package kernel.
"""

import math

import numpy as np

from inins.core import earth, jit

POS, VEL, ATT, BA, BG, CLK, MA, MG = 0, 3, 6, 9, 12, 15, 17, 20
_MA_PAIRS = ((1, 0), (2, 0), (2, 1))
_MG_PAIRS = ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))
_gravity_of_sin2 = jit.njit(cache=True)(earth.gravity_of_sin2)
_radii = jit.njit(cache=True)(earth.principal_radii)


@jit.njit(cache=True)
def _gravity(lat, height):
    """:func:`inins.core.earth.gravity`, compiled (the same arithmetic)."""
    s2 = np.sin(lat) ** 2
    return _gravity_of_sin2(s2, np.sqrt(1.0 - earth.E2 * s2), height)


@jit.njit(cache=True)
def _skew(out, r, c, sign, x, y, z):
    """``out[r:r+3, c:c+3] += sign [v x]``."""
    out[r, c + 1] -= sign * z
    out[r, c + 2] += sign * y
    out[r + 1, c] += sign * z
    out[r + 1, c + 2] -= sign * x
    out[r + 2, c] -= sign * y
    out[r + 2, c + 1] += sign * x


@jit.njit(cache=True)
def earth_jacobians(lat, h, vel, j_v, jie, jen, jg):
    """Fill ``J_v``, ``d w_ie/dr``, ``d w_en/dr``, ``d g/dr`` (each (3, 3)), as the core does."""
    rn, re = _radii(lat)
    rn_h, re_h = rn + h, re + h
    s, c = math.sin(lat), math.cos(lat)
    t = s / c
    w2 = 1.0 - earth.E2 * s * s
    drn = 3.0 * rn * earth.E2 * s * c / w2
    dre = re * earth.E2 * s * c / w2
    vn, ve = vel[0], vel[1]
    j_v.fill(0.0)
    jie.fill(0.0)
    jen.fill(0.0)
    jg.fill(0.0)
    j_v[0, 1] = 1.0 / re_h
    j_v[1, 0] = -1.0 / rn_h
    j_v[2, 1] = -t / re_h
    jen[0, 0] = -ve * dre / re_h**2 / rn_h
    jen[1, 0] = vn * drn / rn_h**2 / rn_h
    jen[2, 0] = (-ve / (c * c * re_h) + ve * t * dre / re_h**2) / rn_h
    jen[0, 2] = ve / re_h**2
    jen[1, 2] = -vn / rn_h**2
    jen[2, 2] = -ve * t / re_h**2
    jie[0, 0] = -earth.RATE * s / rn_h
    jie[2, 0] = -earth.RATE * c / rn_h
    dg_dh = 0.5 * (_gravity(lat, h + 1.0) - _gravity(lat, h - 1.0))
    dg_dlat = (_gravity(lat + 1e-5, h) - _gravity(lat - 1e-5, h)) / 2e-5
    jg[2, 0] = dg_dlat / rn_h
    jg[2, 2] = -dg_dh
    return rn_h, re_h


@jit.njit(cache=True)
def system_matrix26(lat, h, vel, f_b, mat_nb, omega_b, F):
    """Fill ``F`` (n, n), n = 17 or 26, with the error model of :mod:`inins.core.error_model`.

    Parameters: latitude (rad), height (m), NED velocity (3) m/s, body specific
    force (3) m/s^2 and angular rate (3) rad/s (dither-filtered, 003 §2.2),
    ``mat_nb`` (3, 3). ``f_n = mat_nb f_b`` (003 eq. 6).
    """
    n = F.shape[0]
    F.fill(0.0)
    j_v, jie, jen, jg = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
    rn_h, re_h = earth_jacobians(lat, h, vel, j_v, jie, jen, jg)
    w = earth.RATE
    wie = (w * math.cos(lat), 0.0, -w * math.sin(lat))
    wen = (vel[1] / re_h, -vel[0] / rn_h, -vel[1] * math.tan(lat) / re_h)
    f_n = mat_nb @ f_b
    vx = np.zeros((3, 3))
    _skew(vx, 0, 0, 1.0, vel[0], vel[1], vel[2])
    vjv = vx @ j_v
    vjr = vx @ (2.0 * jie + jen) + jg
    _skew(F, POS, POS, -1.0, wen[0], wen[1], wen[2])
    _skew(F, VEL, VEL, -1.0, 2 * wie[0] + wen[0], 2 * wie[1] + wen[1], 2 * wie[2] + wen[2])
    _skew(F, VEL, ATT, 1.0, f_n[0], f_n[1], f_n[2])
    _skew(F, ATT, ATT, -1.0, wie[0] + wen[0], wie[1] + wen[1], wie[2] + wen[2])
    for i in range(3):
        F[POS + i, VEL + i] = 1.0
        for j in range(3):
            F[POS + i, POS + j] -= vjv[i, j]
            F[VEL + i, POS + j] += vjr[i, j]
            F[VEL + i, VEL + j] += vjv[i, j]
            F[VEL + i, BA + j] = mat_nb[i, j]
            F[ATT + i, POS + j] = jie[i, j] + jen[i, j]
            F[ATT + i, VEL + j] = j_v[i, j]
            F[ATT + i, BG + j] = -mat_nb[i, j]
    F[CLK, CLK + 1] = 1.0
    if n >= MG + 6:  # EKF26 (+ inter-system biases, constant states: rows left zero)
        for k in range(3):
            a, b = _MA_PAIRS[k]
            for i in range(3):
                F[VEL + i, MA + k] = mat_nb[i, a] * f_b[b]
        for k in range(6):
            a, b = _MG_PAIRS[k]
            for i in range(3):
                F[ATT + i, MG + k] = -mat_nb[i, a] * omega_b[b]


@jit.njit(cache=True)
def noise26(mat_nb, arw, vrw, ba_rw, bg_rw, clock_bias_psd, clock_drift_psd, Q):
    """Fill ``Q`` (n, n) with ``Qc`` of :func:`inins.core.error_model.noise_matrix`."""
    Q.fill(0.0)
    for i in range(3):
        for j in range(3):
            sv = 0.0
            sa = 0.0
            for k in range(3):
                sv += mat_nb[i, k] * vrw[k] ** 2 * mat_nb[j, k]
                sa += mat_nb[i, k] * arw[k] ** 2 * mat_nb[j, k]
            Q[VEL + i, VEL + j] = sv
            Q[ATT + i, ATT + j] = sa
        Q[BA + i, BA + i] = ba_rw[i] ** 2
        Q[BG + i, BG + i] = bg_rw[i] ** 2
    Q[CLK, CLK] = clock_bias_psd
    Q[CLK + 1, CLK + 1] = clock_drift_psd


@jit.njit(cache=True)
def discretize(F, Qc, dt, Phi, Qd):
    """Third-order transition and process noise series (in place).

    ``Phi = I + A + A^2/2 + A^3/6`` with ``A = F dt``,
    ``Qd = Qc dt + (F Qc + Qc F^T) dt^2/2 + F Qc F^T dt^3/3`` (the Taylor series of
    ``int expm(F s) Qc expm(F s)^T ds``, exact for the position <- velocity and
    clock chains);
    for the INS model at 1 s (``|A|`` ~ 1e-3 apart from the kinematic couplings)
    this agrees with van Loan's exact form to ~1e-5 of the largest entry (tested).
    """
    n = F.shape[0]
    A = F * dt
    A2 = A @ A
    Phi[:, :] = A + 0.5 * A2 + (A2 @ A) / 6.0
    for i in range(n):
        Phi[i, i] += 1.0
    FQ = F @ Qc
    Qd[:, :] = Qc * dt + (FQ + FQ.T) * (0.5 * dt * dt) + (FQ @ F.T) * (dt**3 / 3.0)


@jit.njit(cache=True)
def predict(x, P, Phi, Qd):
    """``x = Phi x``, ``P = Phi P Phi^T + Qd``, symmetrised (in place)."""
    x[:] = Phi @ x
    M = Phi @ P @ Phi.T + Qd
    P[:, :] = 0.5 * (M + M.T)


@jit.njit(cache=True)
def pseudorange_rows(r_ant, v_ant, mat_ne, j_v, lever_n, lever_vel_n, sat_pos, sat_vel, H, zhat):
    """Predicted pseudorange and range rate and their rows of ``H`` (003 eq. 7, spec §6a).

    Rows ``2 i`` (pseudorange) and ``2 i + 1`` (range rate) of satellite ``i``;
    ``zhat`` without clock terms. ``H`` is ``dz / dx`` for the true measurement
    ``z = h(nav (-) x)``: the navigation states are errors (estimate minus true), so
    their columns are minus the sensitivity of ``h`` at the estimate; the clock
    states are the clock values (+1). With ``e`` the unit line of sight (NED),
    ``dv = v_sat - v_ant``, ``rho`` the range, ``l_n`` the lever arm,
    ``u_n = mat_nb (omega_eb_b x l_b)`` its velocity and ``G = -dv^T (I - e e^T) / rho``,
    the sensitivities at the estimate are::

        rho   : pos -e^T,  att -e^T [l_n x]
        rhodot: pos e^T [v_ant x] J_v + G,  vel -e^T,  att -e^T [u_n x] + G [l_n x]

    from ``dr_ant = dr + [l_n x] phi`` and ``dv_ant = dv - [v_ant x] J_v dr + [u_n x] phi``
    (the estimated NED frame is turned by ``J_v dr``).
    """
    H.fill(0.0)
    for i in range(sat_pos.shape[0]):
        d = sat_pos[i] - r_ant
        rho = math.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2)
        e = mat_ne @ (d / rho)
        dv = mat_ne @ (sat_vel[i] - v_ant)
        zhat[2 * i] = rho
        zhat[2 * i + 1] = 0.0
        for k in range(3):
            zhat[2 * i + 1] += dv[k] * e[k]
        edv = zhat[2 * i + 1]
        g = -(dv - edv * e) / rho
        va = mat_ne @ v_ant
        # a^T [b x] phi = a . (b x phi) = (a x b) . phi: the row of a^T [b x] is a x b
        h_att_pr = np.cross(lever_n, e)  # -e^T [l x]
        h_att_rr = np.cross(lever_vel_n, e) + np.cross(g, lever_n)  # -e^T [u x] + G [l x]
        evj = np.cross(e, va) @ j_v  # e^T [v x] J_v
        for k in range(3):
            H[2 * i, POS + k] = e[k]
            H[2 * i, ATT + k] = -h_att_pr[k]
            H[2 * i + 1, POS + k] = -evj[k] - g[k]
            H[2 * i + 1, VEL + k] = e[k]
            H[2 * i + 1, ATT + k] = -h_att_rr[k]
        H[2 * i, CLK] = 1.0
        H[2 * i + 1, CLK + 1] = 1.0


@jit.njit(cache=True)
def sequential_update(x, P, H, y0, r, threshold, accepted, y_out, s_out):
    """Scalar Joseph-form updates in turn, each gated on its own chi-square(1) NIS.

    For row ``i``: ``y = y0_i - H_i dx`` (``dx`` the correction so far), ``s = H_i P H_i^T + r_i``;
    rejected when ``y^2 / s > threshold``; else ``k = P H_i^T / s``, ``dx += k y`` and
    ``P = (I - k H_i) P (I - k H_i)^T + k r_i k^T = P - k (P H_i^T)^T - (P H_i^T) k^T + s k k^T``
    (Joseph form, exact for any gain, O(n^2)). Independent rows (diagonal ``R``) make
    the sequence equal to the batch update of :func:`inins.core.kalman.update`.

    Returns the number of accepted rows; ``x``, ``P``, ``accepted``, ``y_out``,
    ``s_out`` (innovation and its variance, per row) are written in place.
    """
    n = x.shape[0]
    dx = np.zeros(n)
    count = 0
    for i in range(H.shape[0]):
        h = H[i]
        ph = P @ h
        s = h @ ph + r[i]
        y = y0[i] - h @ dx
        y_out[i] = y
        s_out[i] = s
        if y * y > threshold * s:
            accepted[i] = False
            continue
        accepted[i] = True
        count += 1
        k = ph / s
        dx += k * y
        for a in range(n):
            for b in range(a, n):
                v = P[a, b] - k[a] * ph[b] - ph[a] * k[b] + s * k[a] * k[b]
                P[a, b] = v
                P[b, a] = v
    x += dx
    return count


@jit.njit(cache=True)
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


@jit.njit(cache=True)
def mat_en(lat, lon):
    """NED to ECEF (3, 3)."""
    sl, cl, so, co = math.sin(lat), math.cos(lat), math.sin(lon), math.cos(lon)
    return np.array([[-sl * co, -so, -cl * co], [-sl * so, co, -cl * so], [cl, 0.0, -sl]])


@jit.njit(cache=True)
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


@jit.njit(cache=True)
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


@jit.njit(cache=True)
def propagate(x, P, F, Qc, Phi, Qd, quat, vel, lla, omega_b, f_b, dt_k, noise):
    """Model at the mid-interval state, discretise, predict (``dt_k`` > 0).

    ``noise``: arw (3), vrw (3), accel and gyro bias walks (3 each), clock bias and drift
    densities, then one random-walk density (m^2/s) per inter-system bias state (the
    last ``noise.size - 14`` states).
    """
    mat_nb = mat_from_quat(quat)
    system_matrix26(lla[0], lla[2], vel, f_b, mat_nb, omega_b, F)
    if dt_k <= 0.0:
        return
    noise26(mat_nb, noise[0:3], noise[3:6], noise[6:9], noise[9:12], noise[12], noise[13], Qc)
    base = x.shape[0] - (noise.shape[0] - 14)
    for j in range(noise.shape[0] - 14):
        Qc[base + j, base + j] = noise[14 + j]
    discretize(F, Qc, dt_k, Phi, Qd)
    predict(x, P, Phi, Qd)


@jit.njit(cache=True)
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
    omega_eb = omega_b - mat_nb.T @ w_ie
    m_en = mat_en(cl[0], cl[1])
    lever_n = mat_nb @ lever_b
    lever_vel = mat_nb @ np.cross(omega_eb, lever_b)
    r_ant = ecef(cl) + m_en @ lever_n
    v_ant = m_en @ (cv + lever_vel)
    j_v = np.empty((3, 3))
    earth_jacobians(cl[0], cl[2], cv, j_v, np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)))
    H = np.zeros((2 * k, n))
    zhat = np.empty(2 * k)
    pseudorange_rows(r_ant, v_ant, m_en.T, j_v, lever_n, lever_vel, sat_pos, sat_vel, H, zhat)
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
        x[CLK] = np.median(res[ref]) if ref.any() else np.median(res)
        x[CLK + 1] = np.median(z[1::2] - zhat[1::2])
        for c in range(CLK + 2, n):
            own = bias_col == c
            if own.any():
                x[c] = np.median(res[own]) - x[CLK]
    step = 1 if use_rr else 2
    m = (2 * k + step - 1) // step
    y0, Hs, rs = np.empty(m), np.empty((m, n)), np.empty(m)
    for j in range(m):
        i = j * step
        y0[j] = z[i] - zhat[i] - x[CLK + i % 2]
        if i % 2 == 0 and bias_col[i // 2] >= 0:
            y0[j] -= x[bias_col[i // 2]]
        Hs[j] = H[i]
        rs[j] = r[i]
    return sequential_update(x, P, Hs, y0, rs, threshold, acc, y, s)
