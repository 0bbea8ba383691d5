"""Raw converter counts to nominal SI rates, and the checks a raw log must pass first.

A table-free log of raw counts (the imu_tk test data) gives, per sample, counts ``c``
of each triad; the nominal rates are ``w = (c_g - z_g) s_g`` (rad/s) and
``f = (c_a - z_a) s_a`` (m/s^2) with the nominal zeros ``z`` and scales ``s``. An
accelerometer without a nominal scale gets the one-point scale that makes the mean of
the initial static interval read gravity, ``s_a = g / |mean(c_a - z_a)|``.
"""

import numpy as np

CHANNELS = ("accelerometer x", "accelerometer y", "accelerometer z", "gyro x", "gyro y", "gyro z")


def stuck_channels(acc, gyro):
    """Channels (names) whose every sample is the same value: a dead or stuck axis,
    which no calibration can use (the calibrated rotations and gravity norms need every
    axis to move)."""
    both = np.hstack([np.asarray(acc, float), np.asarray(gyro, float)])
    return [CHANNELS[c] for c in range(6) if np.ptp(both[:, c]) == 0.0]


def nominal_rates(time, acc, gyro, accel_zero, gyro_zero, gyro_scale, accel_scale, gravity, init_s):
    """Nominal specific force and rate of a raw-count log.

    Parameters
    ----------
    time : ndarray, shape (n,)
        s.
    acc, gyro : ndarray, shape (n, 3)
        Counts.
    accel_zero, gyro_zero : array_like, shape (3,) or scalar
        Nominal zero (counts).
    gyro_scale : float
        rad/s per count.
    accel_scale : float or None
        m/s^2 per count; None: the one-point scale of the initial ``init_s`` s.
    gravity : float
        m/s^2.
    init_s : float
        Length of the initial static interval (s).

    Returns
    -------
    acc, gyro : ndarray, shape (n, 3)
        m/s^2, rad/s.
    accel_scale : float
        The scale used (m/s^2 per count).

    Raises
    ------
    ValueError
        A stuck axis (every sample the same), or an accelerometer that reads its nominal
        zero over the initial interval (no one-point scale: the zero is wrong, or the
        column is not the accelerometer).
    """
    stuck = stuck_channels(acc, gyro)
    if stuck:
        raise ValueError(
            f"{', '.join(stuck)} give the same count at every sample (stuck or not "
            "connected): no calibration can use them"
        )
    acc = np.asarray(acc, float) - np.asarray(accel_zero, float)
    gyro = (np.asarray(gyro, float) - np.asarray(gyro_zero, float)) * gyro_scale
    if accel_scale is None:
        dt = float(np.median(np.diff(time)))
        n0 = max(1, round(init_s / dt))
        norm = float(np.linalg.norm(acc[:n0].mean(axis=0)))
        if not norm > 0.0:
            raise ValueError(
                "the accelerometers read their nominal zero over the initial interval "
                "(|mean counts - zero| = 0): no one-point scale; check the nominal zero "
                "or give the nominal scale"
            )
        accel_scale = gravity / norm
    return acc * accel_scale, gyro, float(accel_scale)
