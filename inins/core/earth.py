"""WGS84 Earth: radii of curvature, Somigliana normal gravity, Earth and transport rates,
geodetic <-> ECEF.

Functions on scalars broadcast over arrays. They use only ufunc-style numpy so
that :mod:`inins.core.strapdown` can compile the same source with numba
(``njit(earth.gravity_of_sin2)``) instead of keeping a second copy.

References: NIMA TR8350.2 (WGS84) eqs. 4-1 and 4-3.
"""

import numpy as np

A = 6378137.0
"""Semi-major axis (m)."""
F = 1.0 / 298.257223563
"""Flattening."""
B = A * (1.0 - F)
"""Semi-minor axis (m)."""
E2 = F * (2.0 - F)
"""First eccentricity squared."""
RATE = 7.292115e-5
"""Earth rotation rate omega_ie (rad/s)."""
GM = 3.986004418e14
"""Gravitational constant times Earth mass (m^3/s^2)."""
GAMMA_E = 9.7803253359
"""Normal gravity at the equator (m/s^2)."""
GAMMA_P = 9.8321849378
"""Normal gravity at the poles (m/s^2)."""
_K_SOMIGLIANA = B * GAMMA_P / (A * GAMMA_E) - 1.0
_M = RATE**2 * A**2 * B / GM


def principal_radii(lat):
    """Meridian and prime-vertical radii of curvature (m).

    Parameters
    ----------
    lat : float or ndarray
        Geodetic latitude (rad).

    Returns
    -------
    rn, re : float or ndarray
        ``rn`` (north-south, meridian) and ``re`` (east-west, prime vertical).
    """
    s2 = np.sin(lat) ** 2
    w = np.sqrt(1.0 - E2 * s2)
    re = A / w
    rn = re * (1.0 - E2) / (w * w)
    return rn, re


def gravity(lat, height):
    """Somigliana normal gravity with the WGS84 height correction (m/s^2).

    ``gamma(lat) = GAMMA_E (1 + k sin^2 lat) / sqrt(1 - e^2 sin^2 lat)`` and
    ``gamma(lat, h) = gamma(lat) [1 - 2/a (1 + f + m - 2 f sin^2 lat) h + 3 h^2 / a^2]``
    (TR8350.2 eqs. 4-1, 4-3). Normal gravity includes the centrifugal term: a
    body at rest on the Earth senses specific force ``-gravity`` along the down axis.
    """
    s2 = np.sin(lat) ** 2
    return gravity_of_sin2(s2, np.sqrt(1.0 - E2 * s2), height)


def gravity_of_sin2(s2, root, height):
    """:func:`gravity` from ``s2 = sin^2 lat`` and ``root = sqrt(1 - e^2 s2)`` (same arithmetic).

    For callers that already hold ``sin lat`` and the root (the strapdown kernel
    compiles this function with numba, so the source is shared).
    """
    gamma0 = GAMMA_E * (1.0 + _K_SOMIGLIANA * s2) / root
    return gamma0 * (
        1.0 - 2.0 / A * (1.0 + F + _M - 2.0 * F * s2) * height + 3.0 * height * height / (A * A)
    )


def gravity_n(lat, height):
    """Normal gravity vector in NED (m/s^2), shape (..., 3): ``[0, 0, gravity]``."""
    g = np.asarray(gravity(lat, height), dtype=float)
    zero = np.zeros_like(g)
    return np.stack([zero, zero, g], axis=-1)


def rate_ie_n(lat):
    """Earth rate omega_ie in NED (rad/s), shape (..., 3): ``[W cos L, 0, -W sin L]``."""
    lat = np.asarray(lat, dtype=float)
    return np.stack([RATE * np.cos(lat), np.zeros_like(lat), -RATE * np.sin(lat)], axis=-1)


def rate_en_n(lat, height, vel_n):
    """Transport rate omega_en in NED (rad/s), shape (..., 3).

    ``[v_E / (re + h), -v_N / (rn + h), -v_E tan(L) / (re + h)]``.
    """
    rn, re = principal_radii(lat)
    vel_n = np.asarray(vel_n, dtype=float)
    v_n, v_e = vel_n[..., 0], vel_n[..., 1]
    return np.stack(
        [v_e / (re + height), -v_n / (rn + height), -v_e * np.tan(lat) / (re + height)], axis=-1
    )


def ecef_from_llh(lat, lon, height):
    """ECEF position (m), shape (..., 3), from geodetic latitude, longitude (rad), height (m)."""
    _, re = principal_radii(lat)
    cl = np.cos(lat)
    return np.stack(
        [
            (re + height) * cl * np.cos(lon),
            (re + height) * cl * np.sin(lon),
            (re * (1.0 - E2) + height) * np.sin(lat),
        ],
        axis=-1,
    )


def llh_from_ecef(r_e):
    """Geodetic latitude, longitude (rad) and height (m) from ECEF (m), shape (..., 3).

    Iterates the latitude fixed point to machine precision (converges in a few
    steps for any terrestrial or orbital height), at most eight steps, stopping
    early once a step changes no latitude (the next steps would repeat it).
    """
    r_e = np.asarray(r_e, dtype=float)
    x, y, z = r_e[..., 0], r_e[..., 1], r_e[..., 2]
    p = np.hypot(x, y)
    lon = np.arctan2(y, x)
    lat = np.arctan2(z, p * (1.0 - E2))
    for _ in range(8):
        _, re = principal_radii(lat)
        step = np.arctan2(z + E2 * re * np.sin(lat), p)
        if np.array_equal(step, lat, equal_nan=True):
            break
        lat = step
    _, re = principal_radii(lat)
    cl, sl = np.cos(lat), np.sin(lat)
    # height along the normal, stable at all latitudes
    height = p * cl + z * sl - re * (1.0 - E2 * sl * sl)
    return np.stack([lat, lon, height], axis=-1)


def mat_en(lat, lon):
    """``mat_en`` maps NED to ECEF, shape (..., 3, 3)."""
    lat = np.asarray(lat, dtype=float)
    lon = np.asarray(lon, dtype=float)
    sl, cl = np.sin(lat), np.cos(lat)
    so, co = np.sin(lon), np.cos(lon)
    return np.stack(
        [
            np.stack([-sl * co, -so, -cl * co], -1),
            np.stack([-sl * so, co, -cl * so], -1),
            np.stack([cl, np.zeros_like(lat), -sl], -1),
        ],
        axis=-2,
    )
