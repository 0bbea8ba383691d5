"""The calibrated error terms of a gyro and an accelerometer triad, and their compensation.

The sensor model is the one simulate-table applies (:mod:`inins.core.imu`; 000 eq. 2,
003 eqs. 2-5), with the optional gyro g-sensitivity a calibration lab adds::

    w_meas = M_g w + b_g + G f        f_meas = M_a f + b_a

``M_a = I + S_a + A_a`` is lower triangular (the body frame is the accelerometer
triad: ``a_xy = a_xz = a_yz = 0``), ``M_g = I + S_g + B_g`` is full. ``G`` (rad/s per
m/s^2) is the gyro g-sensitivity, zero unless estimated. Term names follow
:data:`inins.core.error_model.GROUPS` (``ba_x``, ``sg_z``, ``mg_xy`` ...), plus
``gg_ij`` (gyro ``i`` per specific force along ``j``) and ``mount_x/y/z``: the small
rotation of the accelerometer triad from its nominal mounting on the table (rad), which
a table calibration finds beside the sensor terms (not a sensor error).
"""

from dataclasses import dataclass

import numpy as np

from inins.core import error_model, rotation

SENSOR_TERMS = tuple(
    n
    for g in (
        "accel_bias",
        "gyro_bias",
        "accel_scale",
        "gyro_scale",
        "accel_misalignment",
        "gyro_misalignment",
    )
    for n in error_model.GROUPS[g]
)
"""The 21 terms of the sensor error model, in this order."""
G_SENS_TERMS = tuple(f"gg_{i}{j}" for i in "xyz" for j in "xyz")
MOUNT_TERMS = ("mount_x", "mount_y", "mount_z")
ALL_TERMS = SENSOR_TERMS + G_SENS_TERMS + MOUNT_TERMS
UNITS = {n: error_model.UNITS[n] for n in SENSOR_TERMS} | {
    **dict.fromkeys(G_SENS_TERMS, "rad/s/(m/s^2)"),
    **dict.fromkeys(MOUNT_TERMS, "rad"),
}
"""SI unit of every term."""

GROUP_OF = {n: g for g, names in error_model.GROUPS.items() for n in names} | {
    **dict.fromkeys(G_SENS_TERMS, "gyro_g_sensitivity"),
    **dict.fromkeys(MOUNT_TERMS, "mount"),
}
"""Group of every term (:data:`inins.core.error_model.GROUPS` names, plus
``gyro_g_sensitivity`` and ``mount``)."""


@dataclass(frozen=True)
class ImuTerms:
    """Values of the error terms (SI), by name; absent terms are zero."""

    values: dict

    def __getitem__(self, name):
        return float(self.values.get(name, 0.0))

    def vector(self, names):
        """Values of ``names`` as an array."""
        return np.array([self[n] for n in names])

    def accel_matrix(self):
        """``M_a`` (lower triangular)."""
        v = self
        return np.array(
            [
                [1.0 + v["sa_x"], 0.0, 0.0],
                [v["ma_yx"], 1.0 + v["sa_y"], 0.0],
                [v["ma_zx"], v["ma_zy"], 1.0 + v["sa_z"]],
            ]
        )

    def gyro_matrix(self):
        """``M_g`` (full)."""
        v = self
        return np.array(
            [
                [1.0 + v["sg_x"], v["mg_xy"], v["mg_xz"]],
                [v["mg_yx"], 1.0 + v["sg_y"], v["mg_yz"]],
                [v["mg_zx"], v["mg_zy"], 1.0 + v["sg_z"]],
            ]
        )

    def g_sensitivity(self):
        """``G`` (rad/s per m/s^2), shape (3, 3)."""
        return self.vector(G_SENS_TERMS).reshape(3, 3)

    def accel_bias(self):
        return self.vector(error_model.GROUPS["accel_bias"])

    def gyro_bias(self):
        return self.vector(error_model.GROUPS["gyro_bias"])

    def mount_matrix(self):
        """``R = exp([m x])``: true accelerometer-triad axes in the nominal body axes."""
        return rotation.mat_from_rotvec(self.vector(MOUNT_TERMS))


def terms_from_sensor(sensor):
    """The 21 terms of a :class:`inins.core.imu.SensorErrors` (simulated truth)."""
    values = {}
    for group, field in (
        ("accel_bias", "accel_bias"),
        ("gyro_bias", "gyro_bias"),
        ("accel_scale", "accel_scale"),
        ("gyro_scale", "gyro_scale"),
        ("accel_misalignment", "accel_misalignment"),
        ("gyro_misalignment", "gyro_misalignment"),
    ):
        for name, value in zip(error_model.GROUPS[group], getattr(sensor, field), strict=True):
            values[name] = float(value)
    return ImuTerms(values)


def terms_from_matrices(mat_a, mat_g, accel_bias, gyro_bias, g_sens=None, mount=None):
    """An :class:`ImuTerms` from ``M_a`` (lower triangular), ``M_g``, biases, ``G``, mount."""
    v = {}
    for i, a in enumerate("xyz"):
        v[f"sa_{a}"] = mat_a[i, i] - 1.0
        v[f"sg_{a}"] = mat_g[i, i] - 1.0
        v[f"ba_{a}"] = accel_bias[i]
        v[f"bg_{a}"] = gyro_bias[i]
    for name in error_model.GROUPS["accel_misalignment"]:
        v[name] = mat_a["xyz".index(name[-2]), "xyz".index(name[-1])]
    for name in error_model.GROUPS["gyro_misalignment"]:
        v[name] = mat_g["xyz".index(name[-2]), "xyz".index(name[-1])]
    if g_sens is not None:
        v.update(zip(G_SENS_TERMS, np.asarray(g_sens).ravel(), strict=True))
    if mount is not None:
        v.update(zip(MOUNT_TERMS, mount, strict=True))
    return ImuTerms({k: float(x) for k, x in v.items()})


def compensate(dtheta, dv, dt, terms):
    """Raw increments corrected for the calibrated errors (the inverse of the model).

    ``dv_c = M_a^-1 (dv - b_a dt)`` and
    ``dtheta_c = M_g^-1 (dtheta - b_g dt - G dv_c)`` per sample, so that increments
    made by the sensor model of the module docstring come back to the true ones
    (to rounding, whatever their size: the inverse is exact, not first order).

    Parameters
    ----------
    dtheta, dv : array_like, shape (n, 3)
        Raw angle (rad) and velocity (m/s) increments, body axes.
    dt : float
        Sample interval (s).
    terms : ImuTerms

    Returns
    -------
    dtheta_c, dv_c : ndarray, shape (n, 3)
    """
    dtheta = np.asarray(dtheta, dtype=float)
    dv = np.asarray(dv, dtype=float)
    dv_c = (dv - terms.accel_bias() * dt) @ np.linalg.inv(terms.accel_matrix()).T
    rhs = dtheta - terms.gyro_bias() * dt - dv_c @ terms.g_sensitivity().T
    return rhs @ np.linalg.inv(terms.gyro_matrix()).T, dv_c
