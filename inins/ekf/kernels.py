"""Compiled per-epoch filter numerics: error model, discretisation, the scalar update.

The filter runs these once per GPS epoch, where the numpy reference functions
(:func:`inins.core.error_model.system_matrix`, :func:`~inins.core.error_model.noise_matrix`,
:func:`inins.core.kalman.discretize`, :func:`inins.core.kalman.update`) would cost
~0.5 ms of interpreter overhead per epoch. They are the same equations:
``tests/ekf/test_kernels.py`` checks :func:`system_matrix26` and :func:`noise26`
against the core to rounding and the discretisation against van Loan.

State order is :data:`inins.core.error_model.EKF26`; :data:`~inins.core.error_model.EKF17`
is its first 17 states, so every function takes the size ``n`` (17 or 26) and
uses the leading block; the inter-system bias states a multi-system filter appends
(at most 4: ``n`` < 26 stays EKF17) have zero rows of ``F``.
"""

import math

import numpy as np

from inins.core import earth, jit
from inins.core.error_model import EKF26, GROUPS

_gravity_of_sin2 = jit.njit(cache=True)(earth.gravity_of_sin2)


@jit.njit(cache=True, error_model="numpy")
def _gravity(lat, height):
    """:func:`inins.core.earth.gravity`, compiled (the same arithmetic)."""
    s2 = np.sin(lat) ** 2
    return _gravity_of_sin2(s2, np.sqrt(1.0 - earth.E2 * s2), height)


_radii = jit.njit(cache=True)(earth.principal_radii)


@jit.njit(cache=True, error_model="numpy")
def mv3(M, v):
    """``M @ v`` for ``M`` (3, 3), ``v`` (3,), written out: a BLAS call for three
    products costs more than they do, and an epoch makes some seventy of them."""
    return np.array(
        [
            M[0, 0] * v[0] + M[0, 1] * v[1] + M[0, 2] * v[2],
            M[1, 0] * v[0] + M[1, 1] * v[1] + M[1, 2] * v[2],
            M[2, 0] * v[0] + M[2, 1] * v[1] + M[2, 2] * v[2],
        ]
    )


@jit.njit(cache=True, error_model="numpy")
def mm3(A, B):
    """``A @ B`` for (3, 3) matrices, written out (:func:`mv3`)."""
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]
    return out


def _start(group):
    return EKF26.slice(group).start


POS, VEL, ATT = _start("position"), _start("velocity"), _start("attitude")
BA, BG, CLK = _start("accel_bias"), _start("gyro_bias"), _start("clock")
MA, MG = _start("accel_misalignment"), _start("gyro_misalignment")
"""The named blocks of EKF26 (:data:`inins.core.error_model.EKF26`), each its group's first
state (clock: bias, then drift); EKF17 is the first 17 states, so the same names serve
both, and the loosely coupled filter's navigation and bias states (spec §6, §6b)."""
NAV = ATT + 3
"""The navigation states (position, velocity, attitude) are ``0:NAV``."""


def _pairs(group):
    return tuple(("xyz".index(n[-2]), "xyz".index(n[-1])) for n in GROUPS[group])


_MA_PAIRS = _pairs("accel_misalignment")  # ma_yx, ma_zx, ma_zy: (i, j) of m_ij
_MG_PAIRS = _pairs("gyro_misalignment")  # mg_xy ... mg_zy


@jit.njit(cache=True, error_model="numpy")
def _skew(out, r, c, sign, x, y, z):
    """``out[r:r+3, c:c+3] += sign [v x]``."""
    out[r, c + 1] -= sign * z
    out[r, c + 2] += sign * y
    out[r + 1, c] += sign * z
    out[r + 1, c + 2] -= sign * x
    out[r + 2, c] -= sign * y
    out[r + 2, c + 1] += sign * x


@jit.njit(cache=True, error_model="numpy")
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


@jit.njit(cache=True, error_model="numpy")
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
    f_n = mv3(mat_nb, f_b)
    vx = np.zeros((3, 3))
    _skew(vx, 0, 0, 1.0, vel[0], vel[1], vel[2])
    vjv = mm3(vx, j_v)
    vjr = mm3(vx, 2.0 * jie + jen) + jg
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


@jit.njit(cache=True, error_model="numpy")
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


@jit.njit(cache=True, error_model="numpy")
def moving_rows(F, diagonal):
    """Indices of the rows of ``F`` (n, n) that differ from ``diagonal`` times the identity
    row (``F``: 0, ``Phi``: 1): the states the model moves."""
    n = F.shape[0]
    rows = np.empty(n, np.int64)
    m = 0
    for i in range(n):
        for j in range(n):
            if F[i, j] != (diagonal if i == j else 0.0):
                rows[m] = i
                m += 1
                break
    return rows[:m]


@jit.njit(cache=True, error_model="numpy")
def discretize(F, Qc, dt, Phi, Qd):
    """Third-order transition and process noise series (in place).

    ``Phi = I + A + A^2/2 + A^3/6`` with ``A = F dt``,
    ``Qd = Qc dt + (F Qc + Qc F^T) dt^2/2 + F Qc F^T dt^3/3`` (the Taylor series of
    ``int expm(F s) Qc expm(F s)^T ds``, exact for the position <- velocity and
    clock chains);
    for the INS model at 1 s (``|A|`` ~ 1e-3 apart from the kinematic couplings)
    this agrees with van Loan's exact form to ~1e-5 of the largest entry (tested).

    Only the ``m`` rows of ``F`` with a nonzero entry (:func:`moving_rows`: the
    navigation states and the clock bias; the sensor and bias states are constants or
    random walks) take part: the products are (m, m) by (m, n), not (n, n) by (n, n).
    """
    n = F.shape[0]
    rows = moving_rows(F, 0.0)
    m = rows.size
    Fr = np.empty((m, n))  # the moving rows
    for i in range(m):
        Fr[i] = F[rows[i]]
    A = Fr * dt
    A2 = np.ascontiguousarray(A[:, rows]) @ A
    A3 = np.ascontiguousarray(A2[:, rows]) @ A
    FQ = Fr @ Qc
    FQF = FQ @ Fr.T
    c2, c3 = 0.5 * dt * dt, dt**3 / 3.0
    for i in range(n):
        for j in range(n):
            Phi[i, j] = 0.0
            Qd[i, j] = Qc[i, j] * dt
        Phi[i, i] = 1.0
    for i in range(m):
        r = rows[i]
        for j in range(n):
            Phi[r, j] = A[i, j] + 0.5 * A2[i, j] + A3[i, j] / 6.0
            Qd[r, j] += FQ[i, j] * c2
            Qd[j, r] += FQ[i, j] * c2
        Phi[r, r] += 1.0
        for j in range(m):
            Qd[r, rows[j]] += FQF[i, j] * c3


@jit.njit(cache=True, error_model="numpy")
def predict(x, P, Phi, Qd):
    """``x = Phi x``, ``P = Phi P Phi^T + Qd``, symmetrised (in place).

    With ``B = Phi - I``, nonzero in the ``m`` rows :func:`moving_rows` finds:
    ``Phi P Phi^T = P + C + C^T + C B^T`` with ``C = B P`` (m, n).
    """
    n = x.shape[0]
    rows = moving_rows(Phi, 1.0)
    m = rows.size
    B = np.empty((m, n))
    for i in range(m):
        B[i] = Phi[rows[i]]
        B[i, rows[i]] -= 1.0
    C = B @ P
    CBt = C @ B.T
    Bx = B @ x
    for i in range(m):
        x[rows[i]] += Bx[i]
    M = P + Qd
    for i in range(m):
        r = rows[i]
        for j in range(n):
            M[r, j] += C[i, j]
            M[j, r] += C[i, j]
        for j in range(m):
            M[r, rows[j]] += CBt[i, j]
    for i in range(n):  # symmetrised, upper triangle mirrored
        for j in range(i, n):
            v = 0.5 * (M[i, j] + M[j, i])
            P[i, j] = v
            P[j, i] = v


@jit.njit(cache=True, error_model="numpy")
def sequential_update(x, P, H, y0, r, threshold, accepted, y_out, s_out):
    """Scalar Joseph-form updates in turn, each gated on its own chi-square(1) NIS.

    For row ``i``: ``y = y0_i - H_i dx`` (``dx`` the correction so far), ``s = H_i P H_i^T + r_i``;
    rejected when ``y^2 / s > threshold``; else ``k = P H_i^T / s``, ``dx += k y`` and
    ``P = (I - k H_i) P (I - k H_i)^T + k r_i k^T = P - k (P H_i^T)^T - (P H_i^T) k^T + s k k^T``
    (Joseph form, exact for any gain, O(n^2)). Independent rows (diagonal ``R``) make
    the sequence equal to the batch update of :func:`inins.core.kalman.update`.

    ``P`` must be symmetric (:func:`predict` and this function leave it exactly so):
    ``P H_i^T`` is summed from the rows of ``P`` at the row's nonzero columns only (a
    pseudorange or range-rate row has at most ten of 26), and the Joseph step is
    written so that entries ``(a, b)`` and ``(b, a)`` round alike.

    Returns the number of accepted rows; ``x``, ``P``, ``accepted``, ``y_out``,
    ``s_out`` (innovation and its variance, per row) are written in place.
    """
    n = x.shape[0]
    dx, ph, k, nz = np.zeros(n), np.empty(n), np.empty(n), np.empty(n, np.int64)
    count = 0
    for i in range(H.shape[0]):
        h = H[i]
        m = 0  # the row's nonzero columns (a pseudorange or range rate: ten at most)
        for a in range(n):
            if h[a] != 0.0:
                nz[m] = a
                m += 1
        ph[:] = 0.0  # P h from the rows of P (symmetric)
        for t in range(m):
            c = nz[t]
            hc, pc = h[c], P[c]
            for a in range(n):
                ph[a] += hc * pc[a]
        s = r[i]
        y = y0[i]
        for t in range(m):
            s += h[nz[t]] * ph[nz[t]]
            y -= h[nz[t]] * dx[nz[t]]
        y_out[i] = y
        s_out[i] = s
        if y * y > threshold * s:
            accepted[i] = False
            continue
        accepted[i] = True
        count += 1
        for a in range(n):
            k[a] = ph[a] / s
            dx[a] += k[a] * y
        for a in range(n):  # symmetric term by term: P stays exactly symmetric
            ka, pa = k[a], ph[a]
            row = P[a]
            for b in range(n):
                row[b] = row[b] - (ka * ph[b] + pa * k[b]) + s * (ka * k[b])
    x += dx
    return count
