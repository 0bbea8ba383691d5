"""The static detector of the table-free method (Tedaldi, Pretto, Menegatti, ICRA 2014
§IV-A, as imu_tk; :mod:`inins.calibration.tablefree`, step 1): the variance of each
accelerometer axis over a centred sliding window against a multiple of the initial
static interval's, and, for the Earth-rate formulation, the gyros too (a turn about the
vertical, which the accelerometers do not see, is then motion).
"""

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Detector:
    """Static-detector settings (SI); see the module docstring."""

    window: float = 1.0
    init: float = 30.0
    threshold_factor: float = 6.0
    min_interval: float = 2.0
    max_tilt: float = np.radians(0.2)


GYRO_STILL = 3e-4
"""Mean rate (rad/s, 62 deg/h) beyond the initial interval's, over a window, that
counts as a turn: above twice the Earth rate, the largest change a new position gives."""


@dataclass(frozen=True)
class StaticInterval:
    """Samples [start, stop) at rest; ``flag`` says why it was dropped ("" = kept)."""

    start: int
    stop: int
    flag: str = ""


def _moving_variance_norm(acc, w):
    """Norm of the per-axis variance over a centred window of ``w`` samples, shape (n,)."""
    n = acc.shape[0]
    c1 = np.vstack([np.zeros((1, 3)), np.cumsum(acc, axis=0)])
    c2 = np.vstack([np.zeros((1, 3)), np.cumsum(acc * acc, axis=0)])
    half = w // 2
    lo = np.clip(np.arange(n) - half, 0, n)
    hi = np.clip(np.arange(n) + half + 1, 0, n)
    cnt = (hi - lo)[:, None]
    mean = (c1[hi] - c1[lo]) / cnt
    var = np.clip((c2[hi] - c2[lo]) / cnt - mean * mean, 0.0, None)
    return np.linalg.norm(var, axis=1)


def detect_static(time, acc, detector, gyro=None):
    """Static intervals of a record (module docstring, step 1).

    ``gyro`` (n, 3) given: a sample is static only where the gyro's variance norm is
    also below ``threshold_factor`` times its initial interval's (at least
    (1e-4 rad/s)^2) and its window mean within :data:`GYRO_STILL` (plus the noise) of
    the initial interval's: turns about the vertical, which the accelerometers do not
    see, are then motion (the Earth-rate formulation integrates every turn and takes each
    static mean as a gyrocompass).

    Returns
    -------
    intervals : list of StaticInterval
        All candidate runs, the flagged ones with their reason.
    threshold : float
        The variance-norm threshold ((m/s^2)^2).
    """
    dt = float(np.median(np.diff(time)))
    w = max(3, round(detector.window / dt) | 1)
    vnorm = _moving_variance_norm(acc, w)
    n_init = round(detector.init / dt)
    init_var = np.var(acc[:n_init], axis=0)
    # floor (1e-5 m/s^2)^2: noise-free data would otherwise have a zero threshold
    threshold = max(detector.threshold_factor * float(np.linalg.norm(init_var)), 1e-10)
    static = vnorm < threshold
    if gyro is not None:
        g_var, g_mean = np.var(gyro[:n_init], axis=0), gyro[:n_init].mean(axis=0)
        limit = detector.threshold_factor * float(np.linalg.norm(g_var))
        static &= _moving_variance_norm(gyro, w) < max(limit, 1e-8)
        # a turn at constant rate has no variance: its mean rate departs from the initial
        # one (by more than the noise of a window mean and twice the Earth rate)
        c = np.vstack([np.zeros((1, 3)), np.cumsum(gyro - g_mean, axis=0)])
        lo, hi = np.clip(np.arange(gyro.shape[0]) - w // 2, 0, None), np.arange(gyro.shape[0])
        hi = np.clip(hi + w // 2 + 1, None, gyro.shape[0])
        shift = np.linalg.norm((c[hi] - c[lo]) / (hi - lo)[:, None], axis=1)
        allow = detector.threshold_factor * np.sqrt(float(g_var.sum()) / w) + GYRO_STILL
        static &= shift < allow
    edges = np.flatnonzero(np.diff(np.concatenate([[0], static.astype(int), [0]])))
    out = []
    min_n = round(detector.min_interval / dt)
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        flag = ""
        if b - a < min_n:
            flag = f"shorter than {detector.min_interval:g} s"
        else:
            fifth = max(1, (b - a) // 5)
            u0 = acc[a : a + fifth].mean(axis=0)
            u1 = acc[b - fifth : b].mean(axis=0)
            cosang = u0 @ u1 / (np.linalg.norm(u0) * np.linalg.norm(u1))
            turn = float(np.arccos(np.clip(cosang, -1.0, 1.0)))
            if turn > detector.max_tilt:
                flag = f"moving: gravity direction turns {np.degrees(turn):.3f} deg"
        out.append(StaticInterval(int(a), int(b), flag))
    return out, threshold
