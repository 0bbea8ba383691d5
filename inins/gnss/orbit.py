"""Satellite position, velocity and clock from broadcast ephemerides.

IS-GPS-200 §20.3.3.4.3 (Table 20-IV, user algorithm for ephemeris
determination), one compiled loop over any number of (set, time) pairs; the velocity
is the analytic time derivative of the same expressions (no finite difference).
Clock: IS-GPS-200 §20.3.3.3.3.1 with the relativistic term
``dtr = F e sqrt(A) sin(E_k)`` and, for single-frequency L1 users, ``- TGD``
(§20.3.3.3.3.2). Times are GPS time (week, seconds of week) of transmission;
positions are in the ECEF frame of that same instant.

The same algorithm serves Galileo (Galileo OS SIS ICD §5.1.1, Table 58) and
BeiDou MEO/IGSO (BDS-SIS-ICD-B1I 3.0 §5.2.4.12) with each system's GM, Earth rate
and relativistic constant (:mod:`inins.gnss.systems`) and its own time (BDT for
BeiDou, :mod:`inins.gnss.timescales`); BeiDou GEO satellites use the ICD's
rotation: the orbit is computed in an inertial-aligned frame (node without
``- omega_e tk``) and rotated by ``R_Z(omega_e tk) R_X(-5 deg)``. GLONASS is in
:mod:`inins.gnss.glonass`.
"""

from dataclasses import dataclass

import numpy as np

from inins.core import jit
from inins.gnss import systems, timescales
from inins.gnss.gpstime import WEEK
from inins.gnss.systems import C  # the speed of light, declared once (systems)

MU = float(systems.GM[systems.GPS])
"""WGS84 Earth gravitational constant for GPS orbits (m^3/s^2), IS-GPS-200 Table 20-IV."""
OMEGA_E = float(systems.OMEGA_E[systems.GPS])
"""WGS84 Earth rotation rate for GPS (rad/s), IS-GPS-200 Table 20-IV."""
F_REL = float(systems.F_REL[systems.GPS])
"""Relativistic clock constant F = -2 sqrt(mu) / c^2 (s/m^0.5), IS-GPS-200 §20.3.3.3.3.1."""
KEPLER_ITERATIONS = 10
"""Most Newton steps on Kepler's equation (from E = M + e sin M; 2-3 reach 1e-15 rad
for GPS eccentricities)."""


@dataclass(frozen=True)
class SatelliteStates:
    """Satellite states at the requested times, in the ECEF frame of those times.

    Attributes
    ----------
    pos : ndarray, shape (..., 3), m
    vel : ndarray, shape (..., 3), m/s (relative to ECEF)
    clock : ndarray, shape (...), m
        ``c * dt_sv`` (relativistic term in; ``- c TGD`` when asked for).
    drift : ndarray, shape (...), m/s
        ``c * d(dt_sv)/dt``.
    """

    pos: np.ndarray
    vel: np.ndarray
    clock: np.ndarray
    drift: np.ndarray


def satellite_states(eph, index, week, sow, *, tgd=False):
    """Satellite ECEF position, velocity and clock at GPS time (week, sow).

    Governing equations: IS-GPS-200 Table 20-IV. ``tk = t - toe`` (wrapped at
    +-302400 s), ``n = sqrt(mu/A^3) + dn``, ``M = M0 + n tk``, Kepler
    ``M = E - e sin E``, argument of latitude ``u = v + omega + cuc cos 2phi +
    cus sin 2phi``, ``r = A (1 - e cos E) + crc cos 2phi + crs sin 2phi``,
    ``i = i0 + idot tk + ...``, node ``Omega = Omega0 + (Omega_dot - omega_e) tk
    - omega_e toe``.

    Parameters
    ----------
    eph : Ephemeris
    index : ndarray of int, shape (...)
        Ephemeris row per state (from :func:`inins.gnss.ephemeris.select`); must be >= 0.
    week : int or ndarray of int, broadcastable to ``index``
    sow : ndarray of float, shape broadcastable to ``index``, s
        GPS time of transmission.
    tgd : bool
        Subtract ``c TGD`` from the clock (single-frequency L1 C/A or P1 user).

    Returns
    -------
    SatelliteStates
    """
    index = np.asarray(index, dtype=np.int64)
    index, week, sow = np.broadcast_arrays(
        index, np.asarray(week, np.int64), np.asarray(sow, float)
    )
    shape = index.shape
    par = np.stack([getattr(eph, name) for name in _PARAMS], axis=1)
    system = systems.system_of(eph.prn)
    if np.any(system == systems.BEIDOU):  # the request in BDT for BeiDou sets
        week, sow = timescales.system_from_gps(system[index], week, sow)
    consts = np.stack(
        [
            systems.GM[system],
            systems.OMEGA_E[system],
            systems.F_REL[system],
            np.array([_is_geo(s) for s in eph.prn.tolist()], float),
        ],
        axis=1,
    )
    args = (
        np.array(index, np.int64).ravel(),
        np.array(week, np.int64).ravel(),
        np.array(sow, float).ravel(),
        par,
        consts,
        eph.week.astype(np.int64),
        bool(tgd),
    )
    if _use_numpy(index.size):
        pos, vel, clock, drift = _states_numpy(*args)
    else:
        pos = np.empty((index.size, 3))
        vel = np.empty((index.size, 3))
        clock = np.empty(index.size)
        drift = np.empty(index.size)
        _states_kernel(*args, pos, vel, clock, drift)
    return SatelliteStates(
        pos=pos.reshape(*shape, 3),
        vel=vel.reshape(*shape, 3),
        clock=clock.reshape(shape),
        drift=drift.reshape(shape),
    )


_PARAMS = (
    "sqrt_a",
    "delta_n",
    "m0",
    "e",
    "omega",
    "cuc",
    "cus",
    "crc",
    "crs",
    "cic",
    "cis",
    "i0",
    "idot",
    "omega0",
    "omega_dot",
    "toe",
    "toc",
    "af0",
    "af1",
    "af2",
    "tgd",
)


def _is_geo(sat):
    return sat // 100 == systems.BEIDOU and sat % 100 in systems.BEIDOU_GEO


_SIN_5, _COS_5 = np.sin(np.radians(-5.0)), np.cos(np.radians(-5.0))


@jit.njit(cache=True)
def _wrap(dt):
    return dt - WEEK * np.floor((dt + 0.5 * WEEK) / WEEK)


@jit.njit(cache=True)
def _states_kernel(index, week, sow, par, consts, eph_week, tgd, pos, vel, clock, drift):
    """IS-GPS-200 Table 20-IV per state (see :func:`satellite_states`); outputs filled in place.

    ``consts[set]`` = (GM, Earth rate, relativistic F, 1.0 for a BeiDou GEO set).
    """
    for k in range(index.size):
        mu, omega_e, f_rel, geo = consts[index[k]]
        (
            sqrt_a,
            delta_n,
            m0,
            e,
            omega,
            cuc,
            cus,
            crc,
            crs,
            cic,
            cis,
            i0,
            idot,
            omega0,
            omega_dot,
            toe,
            toc,
            af0,
            af1,
            af2,
            group_delay,
        ) = par[index[k]]
        weeks = float(week[k] - eph_week[index[k]]) * WEEK
        tk = _wrap(weeks + sow[k] - toe)
        a = sqrt_a * sqrt_a
        n = np.sqrt(mu / (a * a * a)) + delta_n
        mean = m0 + n * tk
        ecc = mean + e * np.sin(mean)
        sin_e, cos_e = np.sin(ecc), np.cos(ecc)
        for _ in range(KEPLER_ITERATIONS):
            step = (ecc - e * sin_e - mean) / (1.0 - e * cos_e)
            ecc -= step
            if abs(step) < 1e-9:  # sin, cos of ecc - step to first order: error < step^2
                sin_e, cos_e = sin_e - cos_e * step, cos_e + sin_e * step
                break
            sin_e, cos_e = np.sin(ecc), np.cos(ecc)
        one_minus = 1.0 - e * cos_e
        ecc_dot = n / one_minus
        beta = np.sqrt(1.0 - e * e)
        phi = np.arctan2(beta * sin_e, cos_e - e) + omega
        nu_dot = beta * ecc_dot / one_minus
        sin_p, cos_p = np.sin(phi), np.cos(phi)
        s2, c2 = 2.0 * sin_p * cos_p, cos_p * cos_p - sin_p * sin_p
        du = cuc * c2 + cus * s2  # ~1e-5 rad: sin, cos by series (error < du^6 / 720)
        du2 = du * du
        sin_du = du * (1.0 - du2 / 6.0 * (1.0 - du2 / 20.0))
        cos_du = 1.0 - du2 / 2.0 * (1.0 - du2 / 12.0)
        su, cu = sin_p * cos_du + cos_p * sin_du, cos_p * cos_du - sin_p * sin_du
        r = a * one_minus + crc * c2 + crs * s2
        inc = i0 + idot * tk + cic * c2 + cis * s2
        u_dot = nu_dot * (1.0 + 2.0 * (cus * c2 - cuc * s2))
        r_dot = a * e * sin_e * ecc_dot + 2.0 * nu_dot * (crs * c2 - crc * s2)
        inc_dot = idot + 2.0 * nu_dot * (cis * c2 - cic * s2)
        node_dot = omega_dot - omega_e if geo == 0.0 else omega_dot
        node = omega0 + node_dot * tk - omega_e * toe
        x_p, y_p = r * cu, r * su
        xp_dot = r_dot * cu - r * su * u_dot
        yp_dot = r_dot * su + r * cu * u_dot
        sn, cn = np.sin(node), np.cos(node)
        si, ci = np.sin(inc), np.cos(inc)
        x = x_p * cn - y_p * ci * sn
        y = x_p * sn + y_p * ci * cn
        z = y_p * si
        vx = xp_dot * cn - yp_dot * ci * sn + y_p * si * sn * inc_dot - y * node_dot
        vy = xp_dot * sn + yp_dot * ci * cn - y_p * si * cn * inc_dot + x * node_dot
        vz = yp_dot * si + y_p * ci * inc_dot
        if geo != 0.0:  # BDS-SIS-ICD 5.2.4.12: R_Z(omega_e tk) R_X(-5 deg)
            yg, zg = _COS_5 * y + _SIN_5 * z, -_SIN_5 * y + _COS_5 * z
            vyg, vzg = _COS_5 * vy + _SIN_5 * vz, -_SIN_5 * vy + _COS_5 * vz
            se, ce = np.sin(omega_e * tk), np.cos(omega_e * tk)
            x, y, z = ce * x + se * yg, -se * x + ce * yg, zg
            vx, vy, vz = (
                ce * vx + se * vyg + omega_e * y,
                -se * vx + ce * vyg - omega_e * x,
                vzg,
            )
        pos[k, 0], pos[k, 1], pos[k, 2] = x, y, z
        vel[k, 0], vel[k, 1], vel[k, 2] = vx, vy, vz
        tc = _wrap(weeks + sow[k] - toc)
        clk = af0 + af1 * tc + af2 * tc * tc + f_rel * e * sqrt_a * sin_e
        if tgd:
            clk -= group_delay
        clock[k] = C * clk
        drift[k] = C * (af1 + 2.0 * af2 * tc + f_rel * e * sqrt_a * cos_e * ecc_dot)


NUMPY_STATES = 300_000
"""Most states computed by numpy array arithmetic (:func:`_states_numpy`) rather than
the compiled loop while numba is not loaded: below it numpy takes at most some 0.2 s,
less than loading numba and the kernel from its cache (0.3-0.5 s of CPU) for a run that
needs no other kernel (a day of SPP at 30 s is some 10^5 states). Once numba is loaded
(a run that uses other kernels) the compiled loop, five times faster, does every
request; the two agree to 1 um."""


def _use_numpy(count):
    """True where ``count`` states are computed by numpy (:data:`NUMPY_STATES`)."""
    # before numba is loaded the kernel is inins.core.jit's lazy Kernel; once loaded
    # (by any kernel's first call) its dispatcher stands in this module's globals
    return count <= NUMPY_STATES and isinstance(_states_kernel, jit.Kernel)


def _states_numpy(index, week, sow, par, consts, eph_week, tgd):
    """:func:`_states_kernel` over all states at once in numpy: the same expressions in
    the same order (the Newton steps on Kepler's equation per state until its own step
    is below 1e-9 rad), so the two agree to the rounding of ``sin`` and ``cos``.
    Returns (pos (n, 3), vel (n, 3), clock (n,), drift (n,))."""
    mu, omega_e, f_rel, geo = consts[index].T
    (sqrt_a, delta_n, m0, e, omega, cuc, cus, crc, crs, cic, cis, i0, idot, omega0,
     omega_dot, toe, toc, af0, af1, af2, group_delay) = par[index].T  # fmt: skip
    weeks = (week - eph_week[index]).astype(float) * WEEK
    tk = _wrap_numpy(weeks + sow - toe)
    a = sqrt_a * sqrt_a
    n = np.sqrt(mu / (a * a * a)) + delta_n
    mean = m0 + n * tk
    ecc = mean + e * np.sin(mean)
    sin_e, cos_e = np.sin(ecc), np.cos(ecc)
    todo = np.arange(len(ecc))
    for _ in range(KEPLER_ITERATIONS):
        ek, sk, ck = ecc[todo], sin_e[todo], cos_e[todo]
        step = (ek - e[todo] * sk - mean[todo]) / (1.0 - e[todo] * ck)
        ek = ek - step
        ecc[todo] = ek
        done = np.abs(step) < 1e-9
        sin_e[todo] = np.where(done, sk - ck * step, np.sin(ek))
        cos_e[todo] = np.where(done, ck + sk * step, np.cos(ek))
        todo = todo[~done]
        if not todo.size:
            break
    one_minus = 1.0 - e * cos_e
    ecc_dot = n / one_minus
    beta = np.sqrt(1.0 - e * e)
    phi = np.arctan2(beta * sin_e, cos_e - e) + omega
    nu_dot = beta * ecc_dot / one_minus
    sin_p, cos_p = np.sin(phi), np.cos(phi)
    s2, c2 = 2.0 * sin_p * cos_p, cos_p * cos_p - sin_p * sin_p
    du = cuc * c2 + cus * s2
    du2 = du * du
    sin_du = du * (1.0 - du2 / 6.0 * (1.0 - du2 / 20.0))
    cos_du = 1.0 - du2 / 2.0 * (1.0 - du2 / 12.0)
    su, cu = sin_p * cos_du + cos_p * sin_du, cos_p * cos_du - sin_p * sin_du
    r = a * one_minus + crc * c2 + crs * s2
    inc = i0 + idot * tk + cic * c2 + cis * s2
    u_dot = nu_dot * (1.0 + 2.0 * (cus * c2 - cuc * s2))
    r_dot = a * e * sin_e * ecc_dot + 2.0 * nu_dot * (crs * c2 - crc * s2)
    inc_dot = idot + 2.0 * nu_dot * (cis * c2 - cic * s2)
    node_dot = np.where(geo == 0.0, omega_dot - omega_e, omega_dot)
    node = omega0 + node_dot * tk - omega_e * toe
    x_p, y_p = r * cu, r * su
    xp_dot = r_dot * cu - r * su * u_dot
    yp_dot = r_dot * su + r * cu * u_dot
    sn, cn = np.sin(node), np.cos(node)
    si, ci = np.sin(inc), np.cos(inc)
    x = x_p * cn - y_p * ci * sn
    y = x_p * sn + y_p * ci * cn
    z = y_p * si
    vx = xp_dot * cn - yp_dot * ci * sn + y_p * si * sn * inc_dot - y * node_dot
    vy = xp_dot * sn + yp_dot * ci * cn - y_p * si * cn * inc_dot + x * node_dot
    vz = yp_dot * si + y_p * ci * inc_dot
    pos, vel = np.stack([x, y, z], axis=1), np.stack([vx, vy, vz], axis=1)
    g = np.flatnonzero(geo != 0.0)
    if g.size:  # BDS-SIS-ICD 5.2.4.12: R_Z(omega_e tk) R_X(-5 deg)
        x, y, z, vx, vy, vz = x[g], y[g], z[g], vx[g], vy[g], vz[g]
        yg, zg = _COS_5 * y + _SIN_5 * z, -_SIN_5 * y + _COS_5 * z
        vyg, vzg = _COS_5 * vy + _SIN_5 * vz, -_SIN_5 * vy + _COS_5 * vz
        w = omega_e[g]
        se, ce = np.sin(w * tk[g]), np.cos(w * tk[g])
        x, y = ce * x + se * yg, -se * x + ce * yg
        pos[g] = np.stack([x, y, zg], axis=1)
        vel[g] = np.stack([ce * vx + se * vyg + w * y, -se * vx + ce * vyg - w * x, vzg], axis=1)
    tc = _wrap_numpy(weeks + sow - toc)
    clk = af0 + af1 * tc + af2 * tc * tc + f_rel * e * sqrt_a * sin_e
    if tgd:
        clk = clk - group_delay
    drift = C * (af1 + 2.0 * af2 * tc + f_rel * e * sqrt_a * cos_e * ecc_dot)
    return pos, vel, C * clk, drift


def _wrap_numpy(dt):
    return dt - WEEK * np.floor((dt + 0.5 * WEEK) / WEEK)


def warm_up():
    """Compile (or load from the on-disk cache) the orbit kernel with the argument types
    :func:`satellite_states` passes."""
    pos, vel = np.empty((1, 3)), np.empty((1, 3))
    clock, drift = np.empty(1), np.empty(1)
    one = np.zeros(1, np.int64)
    par = np.zeros((1, len(_PARAMS)))
    par[0, 0] = 5153.7  # sqrt(A): a GPS orbit
    consts = np.array([[systems.GM[0], systems.OMEGA_E[0], systems.F_REL[0], 0.0]])
    _states_kernel(one, one, np.zeros(1), par, consts, one, False, pos, vel, clock, drift)
