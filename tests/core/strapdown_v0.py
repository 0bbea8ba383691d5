"""Frozen copy of the strapdown kernel before the shared-trigonometry rewrite.

The recursion of ``inins.core.strapdown`` as it was at commit 6ee7f1a (numba
kernel verbatim; ``earth.gravity`` and ``earth.principal_radii`` inlined as they
were then), kept only so that ``test_strapdown_reference.py`` can check the
current kernel against it on the same increments. Not part of the package.
"""

import math

import numba
import numpy as np

A = 6378137.0
F = 1.0 / 298.257223563
B = A * (1.0 - F)
E2 = F * (2.0 - F)
RATE = 7.292115e-5
GM = 3.986004418e14
GAMMA_E = 9.7803253359
GAMMA_P = 9.8321849378
_K_SOMIGLIANA = B * GAMMA_P / (A * GAMMA_E) - 1.0
_M = RATE**2 * A**2 * B / GM


def principal_radii(lat):
    s2 = np.sin(lat) ** 2
    w = np.sqrt(1.0 - E2 * s2)
    re = A / w
    rn = re * (1.0 - E2) / (w * w)
    return rn, re


def gravity(lat, height):
    s2 = np.sin(lat) ** 2
    gamma0 = GAMMA_E * (1.0 + _K_SOMIGLIANA * s2) / np.sqrt(1.0 - E2 * s2)
    return gamma0 * (
        1.0 - 2.0 / A * (1.0 + F + _M - 2.0 * F * s2) * height + 3.0 * height * height / (A * A)
    )


_gravity = numba.njit(cache=True)(gravity)
_radii = numba.njit(cache=True)(principal_radii)
_R_EXTRAPOLATE = 6.371e6
"""Radius (m) used only to extrapolate the mid-interval latitude."""
_FREE, _FIXED_HEIGHT, _FIXED_POSITION, _ZERO_VELOCITY = 0, 1, 2, 3


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def _quat_mul(a0, a1, a2, a3, b0, b1, b2, b3):
    """Hamilton product ``a * b``."""
    return (
        a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
        a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
        a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
        a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0,
    )


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def _cross(ax, ay, az, bx, by, bz):
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


@numba.njit(cache=True)
def _body_terms(th, dv, prev, coning, sculling):
    """Coning-corrected rotation vector and compensated velocity increment (body)."""
    px, py, pz = th[0], th[1], th[2]
    rx, ry, rz = _cross(th[0], th[1], th[2], dv[0], dv[1], dv[2])
    sx, sy, sz = dv[0] + 0.5 * rx, dv[1] + 0.5 * ry, dv[2] + 0.5 * rz
    if coning:
        cx, cy, cz = _cross(prev[0], prev[1], prev[2], th[0], th[1], th[2])
        px, py, pz = px + cx / 12.0, py + cy / 12.0, pz + cz / 12.0
    if sculling:
        ax, ay, az = _cross(prev[0], prev[1], prev[2], dv[0], dv[1], dv[2])
        bx, by, bz = _cross(prev[3], prev[4], prev[5], th[0], th[1], th[2])
        sx, sy, sz = sx + (ax + bx) / 12.0, sy + (ay + by) / 12.0, sz + (az + bz) / 12.0
    return px, py, pz, sx, sy, sz


@numba.njit(cache=True)
def _earth_terms(lla, vel, dt, mode, home):
    """Mid-interval Earth rate (3), R_N + h, R_E + h, latitude, gravity.

    ``home`` holds ``[omega_ie_n (3), R_N + h, R_E + h, lat, gravity]`` of the
    initial position, used as they are in fixed-position mode.
    """
    if mode >= _FIXED_POSITION:
        return home[0], home[1], home[2], home[3], home[4], home[5], home[7]
    lat_m = lla[0] + 0.5 * dt * vel[0] / (_R_EXTRAPOLATE + lla[2])
    h_m = lla[2] if mode == _FIXED_HEIGHT else lla[2] - 0.5 * dt * vel[2]
    rn, re = _radii(lat_m)
    w = RATE
    return (
        w * math.cos(lat_m),
        0.0,
        -w * math.sin(lat_m),
        rn + h_m,
        re + h_m,
        lat_m,
        _gravity(lat_m, h_m),
    )


@numba.njit(cache=True)
def _transport(vx, vy, rn_h, re_h, lat, mode):
    """Transport rate omega_en_n (rad/s); zero in fixed-position mode."""
    if mode >= _FIXED_POSITION:
        return 0.0, 0.0, 0.0
    return vy / re_h, -vx / rn_h, -vy * math.tan(lat) / re_h


@numba.njit(cache=True)
def _velocity_step(vel, u, wie, terms, g, dt, mode):
    """Velocity change (3) and nav-frame rotation vector zeta (3), steps 2-3."""
    rn_h, re_h, lat = terms
    # zero velocity: the velocity is known to be zero, so no Coriolis acts and the
    # computed velocity is the open-loop velocity error (000 eq. 10)
    known = 0.0 if mode == _ZERO_VELOCITY else 1.0
    ex, ey, ez = _transport(vel[0], vel[1], rn_h, re_h, lat, mode)
    cx, cy, cz = _cross(
        2.0 * wie[0] + ex,
        2.0 * wie[1] + ey,
        2.0 * wie[2] + ez,
        known * vel[0],
        known * vel[1],
        known * vel[2],
    )
    mx = vel[0] + 0.5 * (u[0] - cx * dt)
    my = vel[1] + 0.5 * (u[1] - cy * dt)
    mz = vel[2] + 0.5 * (u[2] + (g - cz) * dt)
    ex, ey, ez = _transport(mx, my, rn_h, re_h, lat, mode)
    zx, zy, zz = (wie[0] + ex) * dt, (wie[1] + ey) * dt, (wie[2] + ez) * dt
    rx, ry, rz = _cross(zx, zy, zz, u[0], u[1], u[2])
    cx, cy, cz = _cross(
        2.0 * wie[0] + ex, 2.0 * wie[1] + ey, 2.0 * wie[2] + ez, known * mx, known * my, known * mz
    )
    return (
        (u[0] - 0.5 * rx - cx * dt, u[1] - 0.5 * ry - cy * dt, u[2] - 0.5 * rz + (g - cz) * dt),
        (zx, zy, zz),
    )


@numba.njit(cache=True, nogil=True)
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
    """Run the recursion over all samples; state arrays are updated in place."""
    q0, q1, q2, q3 = quat[0], quat[1], quat[2], quat[3]
    j = 0
    for k in range(dtheta.shape[0]):
        th, dvk = dtheta[k], dv[k]
        px, py, pz, sx, sy, sz = _body_terms(th, dvk, prev, coning, sculling)
        u = _rotate(q0, q1, q2, q3, sx, sy, sz)
        wx, wy, wz, rn_h, re_h, lat_m, g = _earth_terms(lla, vel, dt, mode, home)
        dvn, zeta = _velocity_step(vel, u, (wx, wy, wz), (rn_h, re_h, lat_m), g, dt, mode)
        b = _quat_of_rotvec(px, py, pz)
        q0, q1, q2, q3 = _quat_mul(q0, q1, q2, q3, b[0], b[1], b[2], b[3])
        n = _quat_of_rotvec(-zeta[0], -zeta[1], -zeta[2])
        q0, q1, q2, q3 = _quat_mul(n[0], n[1], n[2], n[3], q0, q1, q2, q3)
        s = 1.5 - 0.5 * (q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
        q0, q1, q2, q3 = q0 * s, q1 * s, q2 * s, q3 * s
        mean_n, mean_e, mean_d = (
            vel[0] + 0.5 * dvn[0],
            vel[1] + 0.5 * dvn[1],
            vel[2] + 0.5 * dvn[2],
        )
        vel[0], vel[1], vel[2] = vel[0] + dvn[0], vel[1] + dvn[1], vel[2] + dvn[2]
        if mode < _FIXED_POSITION:
            lla[0] += mean_n * dt / rn_h
            lla[1] += mean_e * dt / (re_h * math.cos(lat_m))
        if mode == _FREE:
            lla[2] -= mean_d * dt
        for i in range(3):
            prev[i], prev[3 + i] = th[i], dvk[i]
        if (count + k + 1) % decimation == 0:
            out_index[j] = count + k
            out_quat[j, 0], out_quat[j, 1], out_quat[j, 2], out_quat[j, 3] = q0, q1, q2, q3
            out_vel[j, :] = vel
            out_lla[j, :] = lla
            j += 1
    quat[0], quat[1], quat[2], quat[3] = q0, q1, q2, q3


def _home(lla):
    """As the old ``strapdown._home`` with ``earth.rate_ie_n`` (numpy, not numba)."""
    lat = np.asarray(lla[0], dtype=float)
    rn, re = principal_radii(lla[0])
    rate = [RATE * np.cos(lat), 0.0, -RATE * np.sin(lat)]
    return np.array([*rate, rn + lla[2], re + lla[2], lla[0], 0.0, gravity(lla[0], lla[2])])


def integrate(
    quat,
    vel,
    lla,
    dtheta,
    dv,
    dt,
    *,
    fixed_position=False,
    fixed_height=False,
    zero_velocity=False,
    decimation=1,
):
    """Old recursion from a fresh start (no previous sample); the kept outputs as a tuple
    ``(index, quat_nb, vel_n, lla)``, same meaning as ``NavSeries``."""
    dtheta = np.ascontiguousarray(dtheta, dtype=float)
    dv = np.ascontiguousarray(dv, dtype=float)
    n = dtheta.shape[0]
    m = n // decimation
    out = (np.empty(m, np.int64), np.empty((m, 4)), np.empty((m, 3)), np.empty((m, 3)))
    quat, vel, lla = (np.array(x, dtype=float) for x in (quat, vel, lla))
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
        np.zeros(6),
        0,
        dtheta,
        dv,
        float(dt),
        mode,
        True,
        True,
        decimation,
        _home(lla),
        *out,
    )
    return out
