"""Is a record at rest on the Earth what its declared units say? The mean specific force
of a unit at rest is local gravity and its mean rate the Earth rate plus the gyro bias;
a unit mistake moves them by a known factor (g against m/s^2: 9.81; deg against rad:
57.3; milli-units: 1000), which this module names.

The accelerometer check always applies (|f| must be gravity within 10 %: no bias or scale
factor of a working accelerometer is near that). The gyro check takes the sensor's grade
into account: a gyro quiet enough for navigation (angle random walk at most
:data:`QUIET_ARW`, a ring-laser or fibre-optic gyro, whose bias is a fraction of a deg/h)
must read the Earth rate within :data:`EARTH_TOLERANCE`; a noisier (MEMS) gyro, whose
bias may be hundreds of deg/h, must read less than :data:`MEMS_LIMIT` at rest.
"""

import math

import numpy as np

from inins.core import earth
from inins.core.units import DEG_RTH, DPH, DPS, G0

FACTORS = {
    "g declared as m/s^2 (or the reverse)": G0,
    "deg declared as rad (or the reverse)": 180.0 / math.pi,
    "a milli-unit declared as the unit (or the reverse)": 1000.0,
}
"""Ratios a unit mistake gives, and what it is."""
GRAVITY_TOLERANCE = 0.1
"""Relative departure of |f| from local gravity beyond which a record at rest is refused."""
QUIET_ARW = 0.005 * DEG_RTH
"""Angle random walk (rad/sqrt(s)) up to which a gyro counts as navigation grade."""
EARTH_TOLERANCE = 5.0 * DPH
"""Departure of a navigation-grade gyro's |w| at rest from the Earth rate (rad/s)."""
MEMS_LIMIT = 20.0 * DPS
"""Largest |w| (rad/s) any gyro reads at rest (a MEMS bias is below a few deg/s)."""


def _mistake(ratio):
    """The unit mistake whose factor ``ratio`` is closest to (within 15 %), or ""."""
    for what, factor in FACTORS.items():
        for f in (factor, 1.0 / factor):
            if abs(ratio / f - 1.0) < 0.15:
                return f"{what}, a factor {f:.4g}?"
    return ""


def gravity_problem(f_mean, lat=None, height=0.0):
    """A message when the mean specific force (3,) (m/s^2) of a record at rest is not
    local gravity (normal gravity at ``lat``, rad; 9.80665 without), else ""."""
    g = float(earth.gravity(lat, height)) if lat is not None else G0
    f = float(np.linalg.norm(f_mean))
    if abs(f / g - 1.0) <= GRAVITY_TOLERANCE:
        return ""
    if f < 0.01 * g:
        cause = "no gravity at all: is the record at rest, and are these the accelerometers?"
    else:
        cause = _mistake(f / g) or "check the accelerometer unit and scale"
    return f"specific force at rest reads {f:.4g} m/s^2 ({f / g:.4g} g): {cause}"


def rate_problem(w_mean, arw, lat=None):
    """A message when the mean rate (3,) (rad/s) of a record at rest cannot be the Earth
    rate plus a bias of the gyro's grade (``arw``, rad/sqrt(s), the largest axis), else
    ""."""
    w = float(np.linalg.norm(w_mean))
    if w > MEMS_LIMIT:
        cause = _mistake(w / earth.RATE) or _mistake(w / MEMS_LIMIT) or "check the gyro unit"
        return f"angular rate at rest reads {w / DPS:.4g} deg/s, more than any gyro bias: {cause}"
    if arw > QUIET_ARW:
        return ""
    expected = earth.RATE
    if abs(w - expected) <= EARTH_TOLERANCE:
        return ""
    cause = _mistake(w / expected) or (
        "no Earth rate: is the record at rest, and are these the gyros?"
        if w < 0.1 * expected
        else "check the gyro unit and scale"
    )
    return (
        f"angular rate at rest reads {w / DPH:.4g} deg/h where a gyro of this noise "
        f"({arw / DEG_RTH:.3g} deg/sqrt(h), navigation grade) reads the Earth rate "
        f"{expected / DPH:.4g} deg/h: {cause}"
    )
