"""Signal propagation: travel time and Earth rotation (Sagnac), line of sight,
elevation and azimuth, troposphere, ionosphere.

- Sagnac: a satellite position computed at transmit time in the ECEF frame of
  that time is rotated about z by ``omega_e tau`` into the ECEF frame of the
  receive time (spec §6a; IS-GPS-200 §20.3.3.4.3.3.2).
- Troposphere: Saastamoinen (1972) zenith delays with the standard atmosphere
  (p0 = 1013.25 hPa, T0 = 288.15 K, 50 % humidity at sea level; the model of
  RTKLIB ``tropmodel``), mapped by ``1 / cos z`` (the simple mapping function).
- Ionosphere: the ionosphere-free combination of P1 and P2 (first order
  removed exactly), or the Klobuchar model (IS-GPS-200 §20.3.3.5.2.5) from the
  alpha, beta coefficients of a navigation header.
"""

import numpy as np

from inins.core import earth
from inins.gnss.orbit import OMEGA_E, C

F_L1 = 1575.42e6
"""GPS L1 frequency (Hz)."""
F_L2 = 1227.60e6
"""GPS L2 frequency (Hz)."""
LAMBDA_L1 = C / F_L1
"""GPS L1 wavelength (m), 0.1902936728 m: Doppler (Hz) = -range rate / LAMBDA_L1."""
GAMMA_12 = (F_L1 / F_L2) ** 2
"""(f1/f2)^2 = (77/60)^2."""


def sagnac_rotate(vec_e, travel_time):
    """Rotate ECEF vectors of transmit time into the ECEF frame of receive time.

    ``vec_rx = Rz(-omega_e tau) vec_tx`` (the frame has turned by ``omega_e tau``).

    Parameters
    ----------
    vec_e : ndarray, shape (..., 3)
    travel_time : ndarray, shape (...), s

    Returns
    -------
    ndarray, shape (..., 3)
    """
    ang = OMEGA_E * np.asarray(travel_time, dtype=float)
    ca, sa = np.cos(ang), np.sin(ang)
    x, y = vec_e[..., 0], vec_e[..., 1]
    out = np.empty(np.broadcast_shapes(vec_e.shape, (*ang.shape, 3)))
    out[..., 0] = ca * x + sa * y
    out[..., 1] = -sa * x + ca * y
    out[..., 2] = vec_e[..., 2]
    return out


def geometry(sat_pos, sat_vel, rx_pos, rx_vel=None):
    """Range, range rate and line of sight with Earth rotation during travel.

    ``rho = |R(omega_e tau) r_sat - r_rx|`` with ``tau = rho / c`` (two
    fixed-point steps: converged to < 1 um). The range rate is the exact time
    derivative at the receiver, ``drho/dt = (A - los . v_rx) / (1 + (A - B) / c)``
    with ``A = los . R v_sat`` and ``B = omega_e los . (y', -x', 0)`` (the
    satellite is seen at ``t - tau(t)``; the factor is 1 +- 3e-6, a few mm/s).

    Parameters
    ----------
    sat_pos, sat_vel : ndarray, shape (..., 3), m, m/s
        At transmit time, in the ECEF frame of transmit time.
    rx_pos : ndarray, shape (..., 3), m (broadcast against the satellites)
    rx_vel : ndarray, shape (..., 3), m/s, optional (zero)

    Returns
    -------
    rng : ndarray, shape (...), m
    rate : ndarray, shape (...), m/s
        Positive when the range grows.
    los : ndarray, shape (..., 3)
        Unit vector from receiver to satellite (receive-time ECEF).
    scale : ndarray, shape (...)
        ``1 / (1 + (A - B) / c)``: ``d rate / d v_rx = -scale * los``.
    """
    rng, los, pos = range_los(sat_pos, rx_pos)
    vel = sagnac_rotate(sat_vel, rng / C)
    a = _dot(vel, los)
    b = OMEGA_E * (los[..., 0] * pos[..., 1] - los[..., 1] * pos[..., 0])
    scale = 1.0 / (1.0 + (a - b) / C)
    rx_rate = 0.0 if rx_vel is None else _dot(rx_vel, los)
    return rng, (a - rx_rate) * scale, los, scale


def range_los(sat_pos, rx_pos):
    """Range (m), line of sight and satellite position of :func:`geometry` (receive-time
    ECEF), without the range rate: ``rho = |R(omega_e tau) r_sat - r_rx|``, two
    fixed-point steps in ``tau = rho / c``.

    Returns
    -------
    rng : ndarray, shape (...), m
    los : ndarray, shape (..., 3)
    pos : ndarray, shape (..., 3), m, the satellite rotated into the receive-time frame
    """
    rng = _norm(sat_pos - rx_pos)
    for _ in range(2):
        pos = sagnac_rotate(sat_pos, rng / C)
        rng = _norm(pos - rx_pos)
    return rng, (pos - rx_pos) / rng[..., None], pos


def _norm(vec):
    return np.sqrt(_dot(vec, vec))


def _dot(a, b):
    """Dot product over the last axis (of three): written out, as numpy's einsum costs
    several times more on these sizes."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def ned_of_ecef(mat_en, vec_e):
    """``mat_en^T vec_e``: ECEF vectors (..., 3) in the NED frames ``mat_en`` (..., 3, 3)
    (broadcast: one frame per receiver, (n, 1, 3, 3), for its satellites), by matmul."""
    return (vec_e[..., None, :] @ mat_en)[..., 0, :]


def elevation_azimuth(los, rx_pos):
    """Elevation and azimuth (rad) of lines of sight seen from ECEF points.

    Parameters
    ----------
    los : ndarray, shape (..., 3)
        Unit vectors in ECEF.
    rx_pos : ndarray, shape (..., 3), m
        Broadcastable against ``los`` (one receiver for many satellites: (n, 1, 3)).

    Returns
    -------
    elevation : ndarray, shape (...), rad, in [-pi/2, pi/2]
    azimuth : ndarray, shape (...), rad, clockwise from north, in [0, 2 pi)
    """
    lla = earth.llh_from_ecef(rx_pos)
    los_n = ned_of_ecef(earth.mat_en(lla[..., 0], lla[..., 1]), los)
    elevation = np.arcsin(np.clip(-los_n[..., 2], -1.0, 1.0))
    azimuth = np.mod(np.arctan2(los_n[..., 1], los_n[..., 0]), 2.0 * np.pi)
    return elevation, azimuth


def troposphere_saastamoinen(height, lat, elevation, humidity=0.5):
    """Slant tropospheric delay (m): Saastamoinen with the standard atmosphere.

    Standard atmosphere at height h (m, clipped to [0, 11 km] for the
    atmosphere): ``p = 1013.25 (1 - 2.2557e-5 h)^5.2568`` hPa,
    ``T = 15 - 6.5e-3 h + 273.15`` K, water vapour pressure
    ``e = 6.108 RH exp((17.15 T - 4684) / (T - 38.45))`` hPa. Delay
    ``0.002277 / cos z (p + (1255/T + 0.05) e - tan^2 z)`` with zenith angle
    ``z`` (the ``1/cos z`` mapping; Saastamoinen 1972, as in RTKLIB).

    Parameters
    ----------
    height : ndarray, m (ellipsoidal; used as height above sea level)
    lat : ndarray, rad (kept for the interface of latitude-dependent models)
    elevation : ndarray, rad
    humidity : float, relative humidity 0-1 at the receiver

    Returns
    -------
    ndarray, m; zero for elevation <= 0 or height outside [-100 m, 10 km].
    """
    del lat
    h = np.clip(np.asarray(height, dtype=float), 0.0, 1.1e4)
    el = np.asarray(elevation, dtype=float)
    p = 1013.25 * (1.0 - 2.2557e-5 * h) ** 5.2568
    temp = 15.0 - 6.5e-3 * h + 273.15
    e = 6.108 * humidity * np.exp((17.15 * temp - 4684.0) / (temp - 38.45))
    z = np.pi / 2.0 - np.clip(el, 1e-3, None)
    delay = 0.002277 / np.cos(z) * (p + (1255.0 / temp + 0.05) * e - np.tan(z) ** 2)
    valid = (el > 0.0) & (np.asarray(height) > -100.0) & (np.asarray(height) < 1e4)
    return np.where(valid, delay, 0.0)


def ionosphere_klobuchar(sow, lat, lon, elevation, azimuth, alpha, beta):
    """L1 ionospheric delay (m), Klobuchar model, IS-GPS-200 §20.3.3.5.2.5.

    Parameters
    ----------
    sow : ndarray, s (GPS seconds of week of reception)
    lat, lon : ndarray, rad (receiver geodetic)
    elevation, azimuth : ndarray, rad
    alpha, beta : array_like, shape (4,)
        Coefficients as broadcast (s, s/sc, s/sc^2, s/sc^3 and s, s/sc, ...).

    Returns
    -------
    ndarray, m (for L2 multiply by ``GAMMA_12``)
    """
    el_sc = np.asarray(elevation) / np.pi
    psi = 0.0137 / (el_sc + 0.11) - 0.022
    phi_i = np.clip(np.asarray(lat) / np.pi + psi * np.cos(azimuth), -0.416, 0.416)
    lam_i = np.asarray(lon) / np.pi + psi * np.sin(azimuth) / np.cos(phi_i * np.pi)
    phi_m = phi_i + 0.064 * np.cos((lam_i - 1.617) * np.pi)
    t = np.mod(4.32e4 * lam_i + np.asarray(sow), 86400.0)
    amp = np.maximum(np.polyval(np.asarray(alpha, float)[::-1], phi_m), 0.0)
    per = np.maximum(np.polyval(np.asarray(beta, float)[::-1], phi_m), 72000.0)
    x = 2.0 * np.pi * (t - 50400.0) / per
    obliquity = 1.0 + 16.0 * (0.53 - el_sc) ** 3
    delay = np.where(np.abs(x) < 1.57, 5e-9 + amp * (1.0 - x**2 / 2.0 + x**4 / 24.0), 5e-9)
    return C * obliquity * delay


def ionosphere_free(p1, p2):
    """Ionosphere-free combination ``(f1^2 P1 - f2^2 P2) / (f1^2 - f2^2)`` (m).

    Works for pseudoranges (m) and range rates (m/s) alike; NaN where either is NaN.
    """
    return (GAMMA_12 * np.asarray(p1, float) - np.asarray(p2, float)) / (GAMMA_12 - 1.0)
