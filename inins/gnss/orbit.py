"""Satellite position, velocity and clock from broadcast ephemerides.

IS-GPS-200 §20.3.3.4.3 (Table 20-IV, user algorithm for ephemeris
determination), vectorised over any number of (set, time) pairs; the velocity
is the analytic time derivative of the same expressions (no finite difference).
Clock: IS-GPS-200 §20.3.3.3.3.1 with the relativistic term
``dtr = F e sqrt(A) sin(E_k)`` and, for single-frequency L1 users, ``- TGD``
(§20.3.3.3.3.2). Times are GPS time (week, seconds of week) of transmission;
positions are in the ECEF frame of that same instant.
"""

from dataclasses import dataclass

import numpy as np

from inins.gnss import gpstime

MU = 3.986005e14
"""WGS84 Earth gravitational constant for GPS orbits (m^3/s^2), IS-GPS-200 Table 20-IV."""
OMEGA_E = 7.2921151467e-5
"""WGS84 Earth rotation rate for GPS (rad/s), IS-GPS-200 Table 20-IV."""
C = 299792458.0
"""Speed of light (m/s)."""
F_REL = -4.442807633e-10
"""Relativistic clock constant F = -2 sqrt(mu) / c^2 (s/m^0.5), IS-GPS-200 §20.3.3.3.3.1."""
KEPLER_ITERATIONS = 10
"""Newton steps on Kepler's equation; from E = M, 10 reach 1e-15 rad for e < 0.1."""


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


def _kepler(mean_anomaly, e):
    ecc = mean_anomaly.copy()
    for _ in range(KEPLER_ITERATIONS):
        ecc = ecc - (ecc - e * np.sin(ecc) - mean_anomaly) / (1.0 - e * np.cos(ecc))
    return ecc


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
    index, week, sow = np.broadcast_arrays(index, np.asarray(week), np.asarray(sow, float))
    g = {
        k: getattr(eph, k)[index]
        for k in (
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
    }
    tk = gpstime.wrap_week_seconds(gpstime.time_diff(week, sow, eph.week[index], g["toe"]))
    a = g["sqrt_a"] ** 2
    n = np.sqrt(MU / a**3) + g["delta_n"]
    e = g["e"]
    ecc = _kepler(g["m0"] + n * tk, e)
    sin_e, cos_e = np.sin(ecc), np.cos(ecc)
    one_minus = 1.0 - e * cos_e
    ecc_dot = n / one_minus
    beta = np.sqrt(1.0 - e * e)
    nu = np.arctan2(beta * sin_e, cos_e - e)
    nu_dot = beta * ecc_dot / one_minus
    phi = nu + g["omega"]
    s2, c2 = np.sin(2.0 * phi), np.cos(2.0 * phi)
    u = phi + g["cuc"] * c2 + g["cus"] * s2
    r = a * one_minus + g["crc"] * c2 + g["crs"] * s2
    inc = g["i0"] + g["idot"] * tk + g["cic"] * c2 + g["cis"] * s2
    u_dot = nu_dot * (1.0 + 2.0 * (g["cus"] * c2 - g["cuc"] * s2))
    r_dot = a * e * sin_e * ecc_dot + 2.0 * nu_dot * (g["crs"] * c2 - g["crc"] * s2)
    inc_dot = g["idot"] + 2.0 * nu_dot * (g["cis"] * c2 - g["cic"] * s2)
    node_dot = g["omega_dot"] - OMEGA_E
    node = g["omega0"] + node_dot * tk - OMEGA_E * g["toe"]

    su, cu = np.sin(u), np.cos(u)
    x_p, y_p = r * cu, r * su
    xp_dot = r_dot * cu - r * su * u_dot
    yp_dot = r_dot * su + r * cu * u_dot
    sn, cn = np.sin(node), np.cos(node)
    si, ci = np.sin(inc), np.cos(inc)
    pos = np.stack([x_p * cn - y_p * ci * sn, x_p * sn + y_p * ci * cn, y_p * si], axis=-1)
    vel = np.stack(
        [
            xp_dot * cn - yp_dot * ci * sn + y_p * si * sn * inc_dot - pos[..., 1] * node_dot,
            xp_dot * sn + yp_dot * ci * cn - y_p * si * cn * inc_dot + pos[..., 0] * node_dot,
            yp_dot * si + y_p * ci * inc_dot,
        ],
        axis=-1,
    )
    tc = gpstime.wrap_week_seconds(gpstime.time_diff(week, sow, eph.week[index], g["toc"]))
    rel = F_REL * e * g["sqrt_a"] * sin_e
    clock = g["af0"] + g["af1"] * tc + g["af2"] * tc**2 + rel
    if tgd:
        clock = clock - g["tgd"]
    drift = g["af1"] + 2.0 * g["af2"] * tc + F_REL * e * g["sqrt_a"] * cos_e * ecc_dot
    return SatelliteStates(pos=pos, vel=vel, clock=C * clock, drift=C * drift)
