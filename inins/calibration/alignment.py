"""Stationary alignment: coarse levelling and analytic gyrocompassing, and the Earth-rate
check of a standing IMU.

At rest the accelerometers measure ``f_b = -mat_bn g_n`` and the gyros
``omega_b = mat_bn omega_ie_n``. Averaged over the alignment window, the
specific force fixes roll and pitch (levelling) and the horizontal Earth-rate
component fixes the heading (gyrocompassing)::

    mat_nb = Rz(heading) @ L,   L = Ry(pitch) @ Rx(roll)
    omega_L = L @ omega_b = Rz(heading)^T omega_ie_n
            = [W cos(lat) cos(heading), -W cos(lat) sin(heading), -W sin(lat)]
    heading = atan2(-omega_L[1], omega_L[0])

Error budget (white noise; first order): a gyro bias ``eps_E`` along east gives the
heading error ``eps_E / (W cos lat)`` (000 §3.1, 003 eq. 10), an accelerometer bias
``b_N`` along north a tilt ``b_N / g``; angle random walk N over a window T gives a
heading noise ``N / (W cos lat sqrt(T))``.
"""

import enum
from dataclasses import dataclass

import numpy as np

from inins.core import earth, rotation


class HeadingSource(enum.StrEnum):
    """Where an alignment's heading came from."""

    GYROCOMPASS = "gyrocompass"
    GIVEN = "known heading"


@dataclass(frozen=True)
class StationaryAlignment:
    """Result of a stationary alignment.

    Attributes
    ----------
    mat_nb : ndarray, shape (3, 3)
        Attitude at the end of the window.
    omega_b, f_b : ndarray, shape (3,)
        Mean angular rate (rad/s) and specific force (m/s^2) over the window.
    duration : float
        Window length (s).
    heading_sigma : float
        1-sigma heading noise (rad) from the angle random walk given, NaN if unknown.
    tilt_sigma : float
        1-sigma levelling noise (rad) from the velocity random walk given, NaN if unknown.
    method : HeadingSource
    """

    mat_nb: np.ndarray
    omega_b: np.ndarray
    f_b: np.ndarray
    duration: float
    heading_sigma: float
    tilt_sigma: float
    method: HeadingSource

    @property
    def euler(self):
        """Roll, pitch, heading (rad)."""
        return rotation.euler_from_mat(self.mat_nb)


def mean_rates(dtheta, dv, dt):
    """Mean angular rate (rad/s) and specific force (m/s^2) of increments, each (3,)."""
    duration = dtheta.shape[0] * dt
    return np.sum(dtheta, axis=0) / duration, np.sum(dv, axis=0) / duration


def level(f_b):
    """``L = Ry(pitch) @ Rx(roll)`` from the mean specific force (body to level, heading 0)."""
    roll = np.arctan2(-f_b[1], -f_b[2])
    pitch = np.arctan2(f_b[0], np.hypot(f_b[1], f_b[2]))
    return rotation.mat_from_euler(roll, pitch, 0.0)


def gyrocompass_heading(omega_b, f_b):
    """Heading (rad, in [0, 2 pi)) from the horizontal Earth rate after levelling."""
    omega_l = level(f_b) @ omega_b
    return np.mod(np.arctan2(-omega_l[1], omega_l[0]), 2.0 * np.pi)


def earth_rate_check(omega_b, f_b):
    """Earth-rate magnitude (rad/s) and the latitude (rad) the gyros imply.

    At rest the specific force points up, so the up direction is ``f_b / |f_b|``;
    ``sin(lat) = omega_up / W`` and ``cos(lat) = |omega_horizontal| / W``, so
    ``lat = atan2(omega_up, |omega_h|)``.

    Returns
    -------
    rate, lat, horizontal : float
        ``|omega_b|``, implied latitude, horizontal component ``|omega_h|`` (rad/s).
    """
    up = f_b / np.linalg.norm(f_b)
    vertical = float(omega_b @ up)
    horizontal = float(np.linalg.norm(omega_b - vertical * up))
    return float(np.linalg.norm(omega_b)), float(np.arctan2(vertical, horizontal)), horizontal


def align_stationary(dtheta, dv, dt, lat, heading=None, arw=np.nan, vrw=np.nan):
    """Level and gyrocompass (or take a known heading) over a window at rest.

    Parameters
    ----------
    dtheta, dv : ndarray, shape (n, 3)
        Gyro (rad) and accelerometer (m/s) increments of the window.
    dt : float
        Sample interval (s).
    lat : float
        Latitude (rad).
    heading : float, optional
        Known heading (rad); gyrocompassing is skipped.
    arw, vrw : float, optional
        Angle random walk (rad/sqrt(s)) and velocity random walk (m/s/sqrt(s)),
        for the 1-sigma figures.

    Returns
    -------
    Alignment
    """
    omega_b, f_b = mean_rates(dtheta, dv, dt)
    return align_from_means(omega_b, f_b, dtheta.shape[0] * dt, lat, heading, arw, vrw)


def align_from_means(omega_b, f_b, duration, lat, heading=None, arw=np.nan, vrw=np.nan):
    """:func:`align_stationary` from the mean rate (rad/s) and specific force (m/s^2)
    over a window of ``duration`` (s)."""
    method = HeadingSource.GIVEN if heading is not None else HeadingSource.GYROCOMPASS
    if heading is None:
        heading = gyrocompass_heading(omega_b, f_b)
    mat_nb = rotation.axis_rotation(2, heading) @ level(f_b)
    w_h = earth.RATE * np.cos(lat)
    heading_sigma = arw / (w_h * np.sqrt(duration)) if method == HeadingSource.GYROCOMPASS else 0.0
    tilt_sigma = vrw / (np.linalg.norm(f_b) * np.sqrt(duration))
    return StationaryAlignment(
        mat_nb, omega_b, f_b, duration, float(heading_sigma), float(tilt_sigma), method
    )
