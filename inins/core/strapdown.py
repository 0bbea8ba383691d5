"""Strapdown inertial navigation in NED from gyro and accelerometer increments.

Algorithm (Savage, *Strapdown Analytics*, 2nd ed., ch. 7; spec section 2). Sample
``k`` holds ``dtheta_k = int omega_ib_b dt`` and ``dv_k = int f_b dt`` over
``[t_k, t_k + dt]``; the state before it is at ``t_k`` and after it at ``t_k + dt``.
``a, b`` are the previous sample's ``dtheta, dv`` (zero at the start: no
correction). Quantities marked ``_m`` are taken at mid-interval, extrapolated
from the state at ``t_k`` (a midpoint rule for the slow Earth terms, so the
scheme is second order).

1. Body rotation vector with the two-sample coning correction::

       phi = dtheta + (1/12) a x dtheta

2. Specific-force increment with rotation compensation and two-sample sculling,
   resolved in ``n(t_k)`` and rotated to the mid nav frame::

       dv_b  = dv + 1/2 dtheta x dv + (1/12) (a x dv + b x dtheta)
       dv_sf = (I - 1/2 [zeta x]) mat_nb(t_k) dv_b,   zeta = (omega_ie_n + omega_en_n)_m dt

3. Velocity, with normal gravity ``g_n = [0, 0, gamma(lat, h)]`` and Coriolis at
   the predicted mid velocity ``v_m = v + 1/2 (dv_sf + (g_n - (2 omega_ie + omega_en) x v) dt)``::

       v_{k+1} = v_k + dv_sf + (g_n - (2 omega_ie_n + omega_en_n) x v_m) dt

4. Attitude, body and nav-frame rotations by exact quaternions::

       quat_nb <- q(-zeta) * quat_nb * q(phi),   q(r) = [cos |r|/2, sin(|r|/2) r/|r|]

   followed by a first-order renormalisation ``q <- q (3 - |q|^2) / 2``.

5. Position with the trapezoidal velocity ``vbar = (v_k + v_{k+1}) / 2``::

       h += -vbar_D dt,  lat += vbar_N dt / (R_N + h)_m,  lon += vbar_E dt / ((R_E + h) cos lat)_m

The Earth terms (radii, gravity, Earth and transport rates) are evaluated once per
step at the mid latitude from one ``sin, cos`` pair, taken by a series from the
nearest multiple of 2^-10 rad (libm is called only when the latitude enters a new
cell; within 1 ulp of libm). In the free modes ``sqrt(1 - e^2 sin^2 lat)``, its cube
and its inverse are polynomials in the offset from that cell (their coefficients
computed once per cell) and one division gives ``1 / (R_N + h)``, ``1 / (R_E + h)``
and ``1 / cos lat``; the constant factors of the coning, sculling and quaternion
series are products. A step then waits for one square-root-free chain instead of a
square root and five divisions: the free modes run about 15 % faster. Each term is
within a few ulp of the direct evaluation (libm ``sin, cos, tan``, the radii of
:func:`earth.principal_radii`, :func:`earth.gravity`); against the previous kernel
a 1-hour flight differs by 2e-14 rad, 1.4e-10 m/s and 1e-7 m (1e-12 of the
velocity, 1e-13 of the distance flown; the free vertical channel amplifies the
rounding). Fixed-position mode keeps the previous arithmetic and is unchanged to
the last bit.

With ``fixed_position=True`` (rate-table "stationary navigation", 000 eqs. 9-10)
the position stays at its initial value, ``omega_en = 0``, and Earth rate and
gravity are those of the known position; velocity is still integrated (step 3
with ``2 omega_ie x v``), so its error grows open-loop as the 002 in-flight model
describes it. Adding ``zero_velocity=True`` also uses the known zero velocity in
the Coriolis term, so that the computed velocity is the plain integral of the
specific-force error, ``d dv/dt = f_n x phi + mat_nb df`` (000 eq. 10), which is
what the velocity-error calibration fits. With ``fixed_height=True``
only the height is held (no update of ``h`` in step 5, ``h_m = h``): the
horizontal channels stay free-inertial (Schuler) while the vertical channel,
unstable with gravity feedback (time constant ``sqrt(R / 2g)`` ~ 9.5 min), cannot
diverge.
"""

import math
from dataclasses import dataclass, field

import numpy as np

from inins.core import earth, jit, rotation

# numpy error model: no ZeroDivisionError branches. Helpers called once are inlined
# by numba (no separate compilation); the small ones called several times are
# compiled once and inlined by LLVM, which compiles faster than inlining each copy.
_jit = jit.njit(cache=True, error_model="numpy")
_inline = jit.njit(error_model="numpy", inline="always")
_gravity = _inline(earth.gravity_of_sin2)
_R_EXTRAPOLATE = 6.371e6
"""Radius (m) used only to extrapolate the mid-interval latitude."""
_FREE, _FIXED_HEIGHT, _FIXED_POSITION, _ZERO_VELOCITY = 0, 1, 2, 3
_GRID = 2.0**-10
"""Spacing (rad) of the reference latitudes of :func:`_sincos_near`."""
_A_POLAR = earth.A * (1.0 - earth.E2)
"""``R_N root^3``: the meridian radius is ``a (1 - e^2) / root^3`` (m)."""


@_jit
def _quat_of_rotvec(x, y, z):
    """Unit quaternion of the rotation vector ``[x, y, z]`` (rad); series below 0.01 rad."""
    a2 = x * x + y * y + z * z
    if a2 < 1e-4:  # truncation < 3e-17
        c = 1.0 - a2 / 8.0 + a2 * a2 / 384.0
        k = 0.5 - a2 / 48.0 + a2 * a2 / 3840.0
    else:
        a = math.sqrt(a2)
        c = math.cos(0.5 * a)
        k = math.sin(0.5 * a) / a
    return c, k * x, k * y, k * z


@_jit
def _quat_mul(a0, a1, a2, a3, b0, b1, b2, b3):
    """Hamilton product ``a * b``."""
    return (
        a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
        a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
        a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
        a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0,
    )


@_inline
def _rotate(q0, q1, q2, q3, x, y, z):
    """``mat_from_quat(q) @ [x, y, z]``: ``v + w t + r x t`` with ``t = 2 r x v``."""
    tx = 2.0 * (q2 * z - q3 * y)
    ty = 2.0 * (q3 * x - q1 * z)
    tz = 2.0 * (q1 * y - q2 * x)
    return (
        x + q0 * tx + q2 * tz - q3 * ty,
        y + q0 * ty + q3 * tx - q1 * tz,
        z + q0 * tz + q1 * ty - q2 * tx,
    )


@_jit
def _cross(ax, ay, az, bx, by, bz):
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


@_inline
def _body_terms(th, dv, prev, coning, sculling):
    """Coning-corrected rotation vector and compensated velocity increment (body).

    ``th``, ``dv``: this sample's increments, ``prev``: the previous sample's
    ``(dtheta, dv)``, each a 3-tuple of floats.
    """
    px, py, pz = th
    rx, ry, rz = _cross(th[0], th[1], th[2], dv[0], dv[1], dv[2])
    sx, sy, sz = dv[0] + 0.5 * rx, dv[1] + 0.5 * ry, dv[2] + 0.5 * rz
    if coning:
        cx, cy, cz = _cross(prev[0], prev[1], prev[2], th[0], th[1], th[2])
        px, py, pz = px + cx / 12.0, py + cy / 12.0, pz + cz / 12.0
    if sculling:
        ax, ay, az = _cross(prev[0], prev[1], prev[2], dv[0], dv[1], dv[2])
        bx, by, bz = _cross(prev[3], prev[4], prev[5], th[0], th[1], th[2])
        sx, sy, sz = sx + (ax + bx) / 12.0, sy + (ay + by) / 12.0, sz + (az + bz) / 12.0
    return (px, py, pz), (sx, sy, sz)


@_inline
def _sincos_near(d, s0, c0):
    """``sin, cos`` of ``L0 + d`` from ``s0, c0 = sin L0, cos L0``, ``|d| <= 2^-11`` rad.

    ``sin(L0 + d) = s0 cos d + c0 sin d`` with ``cos d = 1 - d^2/2 + d^4/24`` and
    ``sin d = d - d^3/6``: truncation below 3e-19, rounding a few 1e-16 (libm: 1e-16).
    """
    d2 = d * d
    sin_l = (s0 + c0 * d) + d2 * ((-0.5 * s0 - (c0 * (1.0 / 6.0)) * d) + (s0 * (1.0 / 24.0)) * d2)
    cos_l = (c0 - s0 * d) + d2 * ((-0.5 * c0 + (s0 * (1.0 / 6.0)) * d) + (c0 * (1.0 / 24.0)) * d2)
    return sin_l, cos_l


@_inline
def _earth_terms(s, c, h):
    """Earth terms at latitude ``L`` (``s, c = sin L, cos L``) and height ``h`` (m).

    Returns ``(omega_ie_N, omega_ie_D, 1 / (R_N + h), 1 / (R_E + h), tan L, gravity)``:
    Earth rate ``[W cos L, 0, -W sin L]`` (rad/s), inverse radii (1/m) with
    ``root = sqrt(1 - e^2 s^2)``, ``R_E = a / root``, ``R_N = a (1 - e^2) / root^3``
    (one division each), gravity of :func:`earth.gravity` (the same source).
    """
    s2 = s * s
    root = math.sqrt(1.0 - earth.E2 * s2)
    cube = root * root * root
    w = earth.RATE
    return (
        w * c,
        -w * s,
        cube / (_A_POLAR + h * cube),
        root / (earth.A + h * root),
        s / c,
        _gravity(s2, root, h),
    )


@_inline
def _velocity_step(vel, u, wie, terms, g, dt, mode):
    """Velocity change (3) and nav-frame rotation vector zeta (3), steps 2-3.

    ``wie``: Earth rate ``(N, D)`` (its east component is zero); ``terms``:
    ``(1 / (R_N + h), 1 / (R_E + h), tan lat)`` at mid-interval; ``vel``, ``u`` 3-tuples.
    """
    irn, ire, tan_l = terms
    wn, wd = wie
    # zero velocity: the velocity is known to be zero, so no Coriolis acts and the
    # computed velocity is the open-loop velocity error (000 eq. 10)
    known = 0.0 if mode == _ZERO_VELOCITY else 1.0
    free = mode < _FIXED_POSITION
    ex, ey, ez = 0.0, 0.0, 0.0
    if free:  # transport rate omega_en_n at the start velocity
        ex, ey = vel[1] * ire, -vel[0] * irn
        ez = -ex * tan_l
    cx, cy, cz = _cross(
        2.0 * wn + ex, ey, 2.0 * wd + ez, known * vel[0], known * vel[1], known * vel[2]
    )
    mx = vel[0] + 0.5 * (u[0] - cx * dt)
    my = vel[1] + 0.5 * (u[1] - cy * dt)
    mz = vel[2] + 0.5 * (u[2] + (g - cz) * dt)
    if free:  # and at the predicted mid velocity
        ex, ey = my * ire, -mx * irn
        ez = -ex * tan_l
    zx, zy, zz = (wn + ex) * dt, ey * dt, (wd + ez) * dt
    rx, ry, rz = _cross(zx, zy, zz, u[0], u[1], u[2])
    cx, cy, cz = _cross(2.0 * wn + ex, ey, 2.0 * wd + ez, known * mx, known * my, known * mz)
    return (
        (u[0] - 0.5 * rx - cx * dt, u[1] - 0.5 * ry - cy * dt, u[2] - 0.5 * rz + (g - cz) * dt),
        (zx, zy, zz),
    )


@_inline
def _attitude_step(q, phi, zeta):
    """``q(-zeta) * q * q(phi)``, renormalised to first order (step 4)."""
    b0, b1, b2, b3 = _quat_of_rotvec(phi[0], phi[1], phi[2])
    q0, q1, q2, q3 = _quat_mul(q[0], q[1], q[2], q[3], b0, b1, b2, b3)
    n0, n1, n2, n3 = _quat_of_rotvec(-zeta[0], -zeta[1], -zeta[2])
    q0, q1, q2, q3 = _quat_mul(n0, n1, n2, n3, q0, q1, q2, q3)
    s = 1.5 - 0.5 * (q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    return q0 * s, q1 * s, q2 * s, q3 * s


_TWELFTH = 1.0 / 12.0


@_inline
def _velocity_step_free(vel, u, wie, terms, g, dt):
    """:func:`_velocity_step` in the free modes, its sums regrouped so that fewer
    operations wait on the Earth terms of the step (same terms; rounding differs in
    the last bits)."""
    irn, ire, tan_l = terms
    wn, wd = wie
    h_dt = 0.5 * dt
    ire_dt, irn_dt = ire * dt, irn * dt
    ex, ey = vel[1] * ire, -vel[0] * irn  # transport rate at the start velocity
    ez = -ex * tan_l
    cx, cy, cz = _cross(2.0 * wn + ex, ey, 2.0 * wd + ez, vel[0], vel[1], vel[2])
    mx = (vel[0] + 0.5 * u[0]) - h_dt * cx
    my = (vel[1] + 0.5 * u[1]) - h_dt * cy
    mz = (vel[2] + 0.5 * u[2]) + h_dt * (g - cz)
    zx, zy = wn * dt + my * ire_dt, -mx * irn_dt  # and at the predicted mid velocity
    zz = wd * dt - (my * ire_dt) * tan_l
    ex, ey = my * ire, -mx * irn
    ez = -ex * tan_l
    rx, ry, rz = _cross(zx, zy, zz, u[0], u[1], u[2])
    cx, cy, cz = _cross(2.0 * wn + ex, ey, 2.0 * wd + ez, mx, my, mz)
    return (
        (u[0] - 0.5 * rx) - cx * dt,
        (u[1] - 0.5 * ry) - cy * dt,
        (u[2] - 0.5 * rz) + (g - cz) * dt,
    ), (zx, zy, zz)


@_inline
def _body_terms_free(th, dv, prev, coning, sculling):
    """:func:`_body_terms` with the ``1/12`` of the corrections as a product (free modes)."""
    px, py, pz = th
    rx, ry, rz = _cross(th[0], th[1], th[2], dv[0], dv[1], dv[2])
    sx, sy, sz = dv[0] + 0.5 * rx, dv[1] + 0.5 * ry, dv[2] + 0.5 * rz
    if coning:
        cx, cy, cz = _cross(prev[0], prev[1], prev[2], th[0], th[1], th[2])
        px, py, pz = px + cx * _TWELFTH, py + cy * _TWELFTH, pz + cz * _TWELFTH
    if sculling:
        ax, ay, az = _cross(prev[0], prev[1], prev[2], dv[0], dv[1], dv[2])
        bx, by, bz = _cross(prev[3], prev[4], prev[5], th[0], th[1], th[2])
        sx += (ax + bx) * _TWELFTH
        sy += (ay + by) * _TWELFTH
        sz += (az + bz) * _TWELFTH
    return (px, py, pz), (sx, sy, sz)


@_inline
def _quat_of_rotvec_free(x, y, z):
    """:func:`_quat_of_rotvec` with the series in Horner form by constant products."""
    a2 = x * x + y * y + z * z
    if a2 < 1e-4:  # truncation < 3e-17
        c = 1.0 - a2 * (0.125 - a2 * (1.0 / 384.0))
        k = 0.5 - a2 * (1.0 / 48.0 - a2 * (1.0 / 3840.0))
    else:
        a = math.sqrt(a2)
        c = math.cos(0.5 * a)
        k = math.sin(0.5 * a) / a
    return c, k * x, k * y, k * z


@_inline
def _attitude_step_free(q, phi, zeta):
    """:func:`_attitude_step` with :func:`_quat_of_rotvec_free`."""
    b0, b1, b2, b3 = _quat_of_rotvec_free(phi[0], phi[1], phi[2])
    q0, q1, q2, q3 = _quat_mul(q[0], q[1], q[2], q[3], b0, b1, b2, b3)
    n0, n1, n2, n3 = _quat_of_rotvec_free(-zeta[0], -zeta[1], -zeta[2])
    q0, q1, q2, q3 = _quat_mul(n0, n1, n2, n3, q0, q1, q2, q3)
    s = 1.5 - 0.5 * (q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    return q0 * s, q1 * s, q2 * s, q3 * s


_ROOT_SERIES = (0.5, -1.0 / 8.0, 1.0 / 16.0, -5.0 / 128.0)
"""Binomial series of ``(1 + delta)^p`` to ``delta^4`` for ``p = 1/2``, ``3/2``, ``-1/2``."""
_CUBE_SERIES = (1.5, 3.0 / 8.0, -1.0 / 16.0, 3.0 / 128.0)
_INV_ROOT_SERIES = (-0.5, 3.0 / 8.0, -5.0 / 16.0, 35.0 / 128.0)
_GRAVITY_H2 = 3.0 / (earth.A * earth.A)


@_inline
def _composed(scale, q1, q2, q3, q4, a):
    """``scale (1 + a1 delta + ... + a4 delta^4)`` with ``delta = q1 d + ... + q4 d^4``,
    as the coefficients of ``d^0 .. d^4`` (truncated at ``d^4``)."""
    a1, a2, a3, a4 = a
    e2, e3, e4 = q1 * q1, 2.0 * q1 * q2, q2 * q2 + 2.0 * q1 * q3
    f3, f4 = q1 * q1 * q1, 3.0 * q1 * q1 * q2
    g4 = e2 * e2
    return (
        scale,
        scale * (a1 * q1),
        scale * (a1 * q2 + a2 * e2),
        scale * (a1 * q3 + a2 * e3 + a3 * f3),
        scale * (a1 * q4 + a2 * e4 + a3 * f4 + a4 * g4),
    )


@_inline
def _cell_series(s0, c0):
    """Coefficients in ``d`` of ``root``, ``root^3`` and ``1 / root`` at ``L0 + d``
    (``root = sqrt(1 - e^2 sin^2 L)``; ``s0, c0 = sin L0, cos L0``), ``|d| <= 2^-11``.

    ``root(L)^2 / root(L0)^2 = 1 + delta`` with ``delta = -e^2 (sin^2 L - sin^2 L0) /
    root(L0)^2`` and ``sin^2(L0 + d) - sin^2 L0 = sin 2L0 (d - 2/3 d^3) + cos 2L0 (d^2 -
    d^4/3) + O(d^5)``; the binomial series in ``delta`` (``|delta| < 4e-6``) composed to
    ``d^4``: truncation below 1e-19 relative. Computed once per cell of
    :func:`_sincos_near`, so that a step evaluates three polynomials alongside its
    ``sin, cos`` instead of waiting for a square root and a division.
    """
    t0 = 1.0 - earth.E2 * s0 * s0
    r0 = math.sqrt(t0)
    k = -earth.E2 / t0
    p1, p2 = 2.0 * s0 * c0, c0 * c0 - s0 * s0
    q1, q2, q3, q4 = k * p1, k * p2, k * (-2.0 / 3.0) * p1, k * (-1.0 / 3.0) * p2
    return (
        _composed(r0, q1, q2, q3, q4, _ROOT_SERIES),
        _composed(r0 * t0, q1, q2, q3, q4, _CUBE_SERIES),
        _composed(1.0 / r0, q1, q2, q3, q4, _INV_ROOT_SERIES),
    )


@_inline
def _poly4(c, d, d2):
    """``c0 + c1 d + ... + c4 d^4`` (Estrin's scheme: a short dependency chain)."""
    return (c[0] + c[1] * d) + d2 * ((c[2] + c[3] * d) + c[4] * d2)


@_inline
def _earth_terms_free(s, c, h, d, series):
    """:func:`_earth_terms` and ``1 / cos L`` in the free modes, with one division.

    ``root``, ``root^3`` and ``1 / root`` come from the cell's polynomials in ``d``
    (:func:`_cell_series`). With ``X = R_N root^3 + h root^3`` and ``Y = a + h root``
    (so that ``1 / (R_N + h) = root^3 / X`` and ``1 / (R_E + h) = root / Y``) one
    reciprocal ``1 / (X Y c)`` gives ``1 / (R_N + h)``, ``1 / (R_E + h)`` and ``1 / c``
    (``tan L = s / c``); gravity is :func:`earth.gravity`'s formula with ``1 / root``
    as a product. Each term is within a few ulp of the direct evaluation.
    """
    d2 = d * d
    root = _poly4(series[0], d, d2)
    cube = _poly4(series[1], d, d2)
    inv_root = _poly4(series[2], d, d2)
    s2 = s * s
    w = earth.RATE
    x = _A_POLAR + h * cube
    y = earth.A + h * root
    xc, yc = x * c, y * c
    inv = 1.0 / (xc * y)
    inv_c = x * y * inv
    gamma0 = earth.GAMMA_E * (1.0 + earth._K_SOMIGLIANA * s2) * inv_root
    g = gamma0 * (
        1.0
        - 2.0 / earth.A * (1.0 + earth.F + earth._M - 2.0 * earth.F * s2) * h
        + (h * h) * _GRAVITY_H2
    )
    return w * c, -w * s, cube * yc * inv, root * xc * inv, s * inv_c, g, inv_c


@jit.njit(cache=True, nogil=True, error_model="numpy")
def _navigate(
    quat,
    vel,
    lla,
    prev,
    count,
    dtheta,
    dv,
    dt,
    mode,
    coning,
    sculling,
    decimation,
    home,
    out_index,
    out_quat,
    out_vel,
    out_lla,
):
    """Run the recursion over all samples; state arrays are updated in place.

    The state lives in scalars inside the loop (no array views, no reference
    counting per sample); the Earth terms are evaluated once per step.
    """
    q = quat[0], quat[1], quat[2], quat[3]
    v = vel[0], vel[1], vel[2]
    lat, lon, h = lla[0], lla[1], lla[2]
    pre = prev[0], prev[1], prev[2], prev[3], prev[4], prev[5]
    free = mode < _FIXED_POSITION
    half_dt = 0.5 * dt
    # Earth rate (N, D), 1 / (R_N + h), 1 / (R_E + h), tan, gravity: of the known
    # position in fixed-position mode, else recomputed at mid-interval every step
    wn, wd, irn, ire, tan_l, g = home[0], home[2], 0.0, 0.0, 0.0, home[7]
    inv_c = 1.0
    lo, ref, s0, c0 = math.inf, 0.0, 0.0, 1.0  # cell [lo, lo + _GRID) of _sincos_near
    series = _cell_series(s0, c0)
    left = decimation - count % decimation  # samples to the next output
    j = 0
    for k in range(dtheta.shape[0]):
        th = dtheta[k, 0], dtheta[k, 1], dtheta[k, 2]
        dvk = dv[k, 0], dv[k, 1], dv[k, 2]
        if free:
            phi, sf = _body_terms_free(th, dvk, pre, coning, sculling)
        else:
            phi, sf = _body_terms(th, dvk, pre, coning, sculling)
        u = _rotate(q[0], q[1], q[2], q[3], sf[0], sf[1], sf[2])
        if free:
            lat_m = lat + half_dt * v[0] / (_R_EXTRAPOLATE + h)
            h_m = h if mode == _FIXED_HEIGHT else h - half_dt * v[2]
            # sin, cos from those of the nearest multiple L0 of _GRID, a pure function
            # of lat_m (chunked calls stay bit-identical); libm only on a new cell
            if not lo <= lat_m < lo + _GRID:
                cell = math.floor(lat_m * (1.0 / _GRID) + 0.5)
                lo, ref = (cell - 0.5) * _GRID, cell * _GRID
                s0, c0 = math.sin(ref), math.cos(ref)
                series = _cell_series(s0, c0)
            d = lat_m - ref
            s, c = _sincos_near(d, s0, c0)
            wn, wd, irn, ire, tan_l, g, inv_c = _earth_terms_free(s, c, h_m, d, series)
        if free:
            dvn, zeta = _velocity_step_free(v, u, (wn, wd), (irn, ire, tan_l), g, dt)
            q = _attitude_step_free(q, phi, zeta)
        else:
            dvn, zeta = _velocity_step(v, u, (wn, wd), (irn, ire, tan_l), g, dt, mode)
            q = _attitude_step(q, phi, zeta)
        mean_n, mean_e, mean_d = v[0] + 0.5 * dvn[0], v[1] + 0.5 * dvn[1], v[2] + 0.5 * dvn[2]
        v = v[0] + dvn[0], v[1] + dvn[1], v[2] + dvn[2]
        if free:
            lat += mean_n * dt * irn
            lon += mean_e * dt * ire * inv_c
        if mode == _FREE:
            h -= mean_d * dt
        pre = th[0], th[1], th[2], dvk[0], dvk[1], dvk[2]
        left -= 1
        if left == 0:  # outputs after samples i with (i + 1) % decimation == 0
            left = decimation
            out_index[j] = count + k
            out_quat[j, 0], out_quat[j, 1], out_quat[j, 2], out_quat[j, 3] = q
            out_vel[j, 0], out_vel[j, 1], out_vel[j, 2] = v
            out_lla[j, 0], out_lla[j, 1], out_lla[j, 2] = lat, lon, h
            j += 1
    quat[0], quat[1], quat[2], quat[3] = q
    vel[0], vel[1], vel[2] = v
    lla[0], lla[1], lla[2] = lat, lon, h
    for i in range(6):
        prev[i] = pre[i]


def _vector(value, size, name):
    out = np.array(value, dtype=float).reshape(-1)
    if out.shape != (size,) or not np.all(np.isfinite(out)):
        raise ValueError(f"{name} must be {size} finite numbers, got {value!r}")
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class NavState:
    """Navigation state at a sample boundary, carried between :func:`integrate` calls.

    Attributes
    ----------
    quat_nb : ndarray, shape (4,)
        Attitude quaternion, scalar first (normalised on construction if its
        norm is off by more than 1e-12).
    vel_n : ndarray, shape (3,)
        NED velocity relative to the Earth (m/s).
    lla : ndarray, shape (3,)
        ``[lat (rad), lon (rad), height (m)]``.
    dtheta_prev, dv_prev : ndarray, shape (3,)
        Previous sample's increments (rad, m/s) for coning and sculling; zeros
        mean "no previous sample".
    count : int
        Samples integrated since the initial state (sets the decimation phase).
    """

    quat_nb: np.ndarray
    vel_n: np.ndarray
    lla: np.ndarray
    dtheta_prev: np.ndarray = field(default_factory=lambda: np.zeros(3))
    dv_prev: np.ndarray = field(default_factory=lambda: np.zeros(3))
    count: int = 0

    def __post_init__(self):
        quat = _vector(self.quat_nb, 4, "quat_nb")
        norm = np.linalg.norm(quat)
        if not 0.5 < norm < 2.0:
            raise ValueError(f"quat_nb must be a unit quaternion, got norm {norm}")
        if abs(norm - 1.0) > 1e-12:  # leave a propagated state bit-for-bit as it is
            object.__setattr__(self, "quat_nb", _vector(quat / norm, 4, "quat_nb"))
        else:
            object.__setattr__(self, "quat_nb", quat)
        for name in ("vel_n", "lla", "dtheta_prev", "dv_prev"):
            object.__setattr__(self, name, _vector(getattr(self, name), 3, name))
        if int(self.count) != self.count or self.count < 0:
            raise ValueError(f"count must be a non-negative integer, got {self.count!r}")
        object.__setattr__(self, "count", int(self.count))

    @classmethod
    def from_attitude(cls, attitude, vel_n, lla):
        """Initial state (no previous sample) from an attitude, velocity and position.

        Parameters
        ----------
        attitude : array_like, shape (3, 3) or (3,)
            ``mat_nb``, or ``[roll, pitch, heading]`` (rad).
        vel_n : array_like, shape (3,)
            NED velocity (m/s).
        lla : array_like, shape (3,)
            ``[lat (rad), lon (rad), height (m)]``.
        """
        attitude = np.asarray(attitude, dtype=float)
        if attitude.shape == (3,):
            attitude = rotation.mat_from_euler(*attitude)
        if attitude.shape != (3, 3):
            raise ValueError(f"attitude must be mat_nb (3, 3) or Euler (3,), got {attitude.shape}")
        return cls(rotation.quat_from_mat(attitude), vel_n, lla)

    @property
    def mat_nb(self):
        """Attitude matrix, shape (3, 3)."""
        return rotation.mat_from_quat(self.quat_nb)


@dataclass(frozen=True, eq=False)
class NavSeries:
    """Navigation outputs after samples ``index`` (state at ``t0 + (index + 1) dt``).

    Attributes
    ----------
    index : ndarray, shape (m,)
        Sample index since the initial state (int64).
    quat_nb : ndarray, shape (m, 4)
        Attitude quaternions, scalar first.
    vel_n : ndarray, shape (m, 3)
        NED velocity (m/s).
    lla : ndarray, shape (m, 3)
        ``[lat (rad), lon (rad), height (m)]``.
    """

    index: np.ndarray
    quat_nb: np.ndarray
    vel_n: np.ndarray
    lla: np.ndarray

    def __len__(self):
        return self.index.size

    def time(self, dt, t0=0.0):
        """Time (s) of each output, shape (m,): ``t0 + (index + 1) dt``."""
        return t0 + (self.index + 1) * dt

    def mat_nb(self):
        """Attitude matrices, shape (m, 3, 3)."""
        return rotation.mat_from_quat(self.quat_nb)

    def euler(self):
        """Roll, pitch, heading (rad), shape (m, 3); heading in [0, 2 pi)."""
        return rotation.euler_from_mat(self.mat_nb())

    @classmethod
    def concatenate(cls, parts):
        """Join the series of consecutive :func:`integrate` calls."""
        parts = list(parts)
        return cls(
            *(
                np.concatenate([getattr(p, name) for p in parts])
                for name in ("index", "quat_nb", "vel_n", "lla")
            )
        )


def _increments(value, name):
    out = np.ascontiguousarray(value, dtype=float)
    if out.ndim != 2 or out.shape[1] != 3:
        raise ValueError(f"{name} must have shape (n, 3), got {out.shape}")
    return out


def _home(lla):
    """Earth rate (3), R_N + h, R_E + h, lat, (unused), gravity at ``lla``."""
    rn, re = earth.principal_radii(lla[0])
    return np.concatenate(
        [
            earth.rate_ie_n(lla[0]),
            [rn + lla[2], re + lla[2], lla[0], 0.0, earth.gravity(lla[0], lla[2])],
        ]
    )


def integrate(
    state,
    dtheta,
    dv,
    dt,
    *,
    fixed_position=False,
    fixed_height=False,
    coning=True,
    sculling=True,
    decimation=1,
    zero_velocity=False,
):
    """Strapdown navigation over a record of increments (module docstring for the equations).

    Chunked use is exact: integrating a record in pieces, each call starting from
    the state the previous one returned, gives bit-for-bit the result of one call;
    outputs are taken after every sample ``i`` with ``(i + 1) % decimation == 0``,
    ``i`` counted from the initial state (``NavState.count``).

    Parameters
    ----------
    state : NavState
        State at the start of sample 0.
    dtheta : array_like, shape (n, 3)
        Gyro increments ``int omega_ib_b dt`` (rad).
    dv : array_like, shape (n, 3)
        Accelerometer increments ``int f_b dt`` (m/s).
    dt : float
        Sample interval (s).
    fixed_position : bool
        Rate-table mode: position held, ``omega_en = 0``.
    zero_velocity : bool
        With ``fixed_position``: no Coriolis term either, the velocity being known
        to be zero (000 eq. 10).
    fixed_height : bool
        Hold the height (gravity, radii) at its initial value, for long free-inertial
        runs without the unstable vertical channel; ``v_D`` is still integrated.
    coning, sculling : bool
        Apply the two-sample coning / sculling corrections.
    decimation : int
        Keep one output every ``decimation`` samples.

    Returns
    -------
    NavState
        State after the last sample.
    NavSeries
        Kept outputs.
    """
    dtheta = _increments(dtheta, "dtheta")
    dv = _increments(dv, "dv")
    if dv.shape != dtheta.shape:
        raise ValueError(f"dtheta {dtheta.shape} and dv {dv.shape} must have the same shape")
    if not (np.isfinite(dt) and dt > 0.0):
        raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
    if int(decimation) != decimation or decimation < 1:
        raise ValueError(f"decimation must be a positive integer, got {decimation!r}")
    decimation = int(decimation)
    first, n = state.count, dtheta.shape[0]
    m = (first + n) // decimation - first // decimation
    out = (np.empty(m, np.int64), np.empty((m, 4)), np.empty((m, 3)), np.empty((m, 3)))
    quat, vel, lla = state.quat_nb.copy(), state.vel_n.copy(), state.lla.copy()
    prev = np.concatenate([state.dtheta_prev, state.dv_prev])
    if zero_velocity and not fixed_position:
        raise ValueError("zero_velocity needs fixed_position")
    mode = (
        _ZERO_VELOCITY
        if zero_velocity
        else _FIXED_POSITION
        if fixed_position
        else _FIXED_HEIGHT
        if fixed_height
        else _FREE
    )
    _navigate(
        quat,
        vel,
        lla,
        prev,
        first,
        dtheta,
        dv,
        float(dt),
        mode,
        bool(coning),
        bool(sculling),
        decimation,
        _home(lla),
        *out,
    )
    end = NavState(quat, vel, lla, prev[:3], prev[3:], first + n)
    return end, NavSeries(*out)


def coning_drift_rate(half_angle, frequency, dt, corrected=True):
    """Secular attitude drift (rad/s) of the attitude update under classic coning.

    For the coning of :class:`inins.core.trajectory.Coning` (transverse rate
    amplitude ``a = W sin(theta)``) the exact rotation vector over a sample
    exceeds ``dtheta`` along the cone axis by the Bortz term
    ``1/2 int alpha x omega dt = (a / W)^2 (x - sin x) / 2``, ``x = W dt``, while the
    two-sample correction supplies ``(1/12) a x dtheta = (a / W)^2 (2 sin x - sin 2x) / 12``.
    The difference per sample, divided by ``dt``, is the drift rate:
    ``(W sin^2(theta) / 2) (1 - sin x / x)`` ~ ``W^3 sin^2(theta) dt^2 / 12``
    uncorrected, ``W^5 sin^2(theta) dt^4 / 60`` corrected (leading order in theta).
    The computed attitude lags the cone: the phi-angle error grows along the
    +cone axis at this rate.

    Parameters
    ----------
    half_angle : float
        Cone half-angle ``theta`` (rad).
    frequency : float
        Coning frequency ``W / 2 pi`` (Hz).
    dt : float
        Sample interval (s).
    corrected : bool
        With the two-sample coning correction.
    """
    x = 2.0 * np.pi * frequency * dt
    missing = 0.5 * (x - np.sin(x))
    if corrected:
        missing -= (2.0 * np.sin(x) - np.sin(2.0 * x)) / 12.0
    return np.sin(half_angle) ** 2 * missing / dt


def warm_up():
    """Compile (or load from the on-disk cache) the navigation kernel on two samples.

    Every mode runs through the same compiled kernel (the mode is an argument).
    """
    state = NavState.from_attitude(np.eye(3), np.zeros(3), np.array([0.6, 2.2, 0.0]))
    integrate(state, np.zeros((2, 3)), np.zeros((2, 3)), 0.01)


class FreeInertial:
    """Free-inertial navigation carried through consecutive chunks, every sample kept.

    The recursion of :func:`integrate` (free mode, coning and sculling on, no
    decimation) without its per-call objects, for a filter that integrates one short
    chunk per measurement epoch: ``run`` on consecutive chunks gives bit for bit the
    series of one :func:`integrate` call (``tests/ekf/test_step.py``). The current
    state is the arrays ``quat``, ``vel``, ``lla`` (a feedback may correct them in place).

    Parameters
    ----------
    state : NavState
        State at the start of the first chunk.
    """

    def __init__(self, state):
        self.quat = state.quat_nb.copy()
        self.vel = state.vel_n.copy()
        self.lla = state.lla.copy()
        self.prev = np.concatenate([state.dtheta_prev, state.dv_prev])
        self.count = state.count
        self._home = np.zeros(8)  # Earth terms of the fixed-position modes; unused here

    def run(self, dtheta, dv, dt):
        """Integrate a chunk of ``n`` samples.

        Returns
        -------
        start : tuple of ndarray
            ``(quat, vel, lla)`` before the chunk (copies).
        series : tuple of ndarray
            ``(quat (n, 4), vel (n, 3), lla (n, 3))`` after each sample.
        """
        n = dtheta.shape[0]
        index = np.empty(n, np.int64)
        series = (np.empty((n, 4)), np.empty((n, 3)), np.empty((n, 3)))
        start = (self.quat.copy(), self.vel.copy(), self.lla.copy())
        mode, coning, sculling, decimation = _FREE, True, True, 1
        _navigate(
            self.quat,
            self.vel,
            self.lla,
            self.prev,
            self.count,
            np.ascontiguousarray(dtheta),
            np.ascontiguousarray(dv),
            float(dt),
            mode,
            coning,
            sculling,
            decimation,
            self._home,
            index,
            *series,
        )
        self.count += n
        return start, series

    def state(self):
        """The current state as a :class:`NavState`."""
        return NavState(
            self.quat.copy(),
            self.vel.copy(),
            self.lla.copy(),
            self.prev[:3].copy(),
            self.prev[3:].copy(),
            self.count,
        )
