"""Error-state models for observability analysis, built on :mod:`inins.core.error_model`.

Nothing is re-derived here: every system matrix is
:func:`inins.core.error_model.system_matrix` at a segment's operating point,
and every noise density :func:`inins.core.error_model.noise_matrix`.

Models
------
``align12``
    002's 12-state alignment model (eqs. 1-2): dv 3, phi 3, accelerometer bias 3,
    gyro bias 3 (body frame, random constants), NED. 002 takes ``w_en`` as
    given (F11 = -(2 w_ie + w_en)x, no phi <- dv block), so the model is
    ``system_matrix(ALIGN12, ..., transport_from_estimate=False)``. The same
    matrix at rest is the stationary 12-state alignment model.
``align10``
    The classic stationary 10-state model (Bar-Itzhack & Berman, "Control
    theoretic approach to inertial navigation systems", JGCD 11(3), 1988):
    horizontal velocity errors dv_N, dv_E, phi 3, horizontal accelerometer
    biases ba_x, ba_y, gyro biases 3. It is the 12-state model with dv_D and
    ba_z held at zero (vertical channel aided); it is exact for a level body,
    where ba_z has no horizontal component.
``nav15``, ``ekf17``, ``ekf26``
    Free-inertial navigation errors with biases, and 003's EKF1 / EKF2 models
    (clock bias and drift; + accelerometer and gyro misalignments). The INS
    computes its transport rate from its own velocity (Schuler coupling on).
"""

from dataclasses import dataclass

import numpy as np

from inins.core import error_model
from inins.core.error_model import ALIGN12, EKF17, EKF26, NAV15, StateLayout
from inins.exceptions import InputError

ALIGN10 = StateLayout(
    ("dv_N", "dv_E", "phi_N", "phi_E", "phi_D", "ba_x", "ba_y", "bg_x", "bg_y", "bg_z")
)
"""Classic stationary alignment model: horizontal velocity errors only (Bar-Itzhack & Berman)."""


@dataclass(frozen=True)
class Model:
    """An error-state model: a state layout and how the transport rate is formed.

    Attributes
    ----------
    name : str
    layout : StateLayout
    transport_from_estimate : bool
        See :func:`inins.core.error_model.system_matrix`.
    """

    name: str
    layout: StateLayout
    transport_from_estimate: bool

    @property
    def names(self):
        """State names in order."""
        return self.layout.names

    def system_matrices(self, segments):
        """F of every segment, shape (J, n, n)."""
        lla = np.array([s.lla for s in segments])
        return error_model.system_matrix(
            self.layout,
            lla[:, 0],
            lla[:, 2],
            np.array([s.vel_n for s in segments]),
            np.array([s.f_n for s in segments]),
            np.array([s.mat_nb for s in segments]),
            np.array([s.omega_ib_b for s in segments]),
            transport_from_estimate=self.transport_from_estimate,
        )

    def noise_densities(self, segments, noise):
        """Continuous process-noise density Qc of every segment, shape (J, n, n).

        Parameters
        ----------
        segments : sequence of Segment
        noise : ProcessNoise or None
            None gives zero (random constants, 002 eq. 1 without ``w_f``).
        """
        n = len(self.layout)
        if noise is None:
            return np.zeros((len(segments), n, n))
        return error_model.noise_matrix(
            self.layout,
            np.array([s.mat_nb for s in segments]),
            noise.arw,
            noise.vrw,
            accel_bias_rw=noise.accel_bias_rw,
            gyro_bias_rw=noise.gyro_bias_rw,
            clock_bias_psd=noise.clock_bias_psd,
            clock_drift_psd=noise.clock_drift_psd,
        )


@dataclass(frozen=True)
class ProcessNoise:
    """White-noise densities driving the error state (SI).

    Attributes
    ----------
    arw : float or tuple
        Gyro angle random walk (rad/sqrt(s)).
    vrw : float or tuple
        Accelerometer velocity random walk (m/s/sqrt(s)).
    accel_bias_rw, gyro_bias_rw : float
        Bias random walks (m/s^2/sqrt(s), rad/s/sqrt(s)).
    clock_bias_psd, clock_drift_psd : float
        Receiver clock densities (m^2/s, m^2/s^3).
    """

    arw: float = 0.0
    vrw: float = 0.0
    accel_bias_rw: float = 0.0
    gyro_bias_rw: float = 0.0
    clock_bias_psd: float = 0.0
    clock_drift_psd: float = 0.0


MODELS = {
    "align12": Model("align12", ALIGN12, transport_from_estimate=False),
    "align10": Model("align10", ALIGN10, transport_from_estimate=False),
    "nav15": Model("nav15", NAV15, transport_from_estimate=True),
    "ekf17": Model("ekf17", EKF17, transport_from_estimate=True),
    "ekf26": Model("ekf26", EKF26, transport_from_estimate=True),
}
"""The model library by name."""


def model_by_name(name, key="model"):
    """The :data:`MODELS` entry ``name``; :class:`InputError` naming ``key`` if unknown."""
    try:
        return MODELS[name]
    except KeyError:
        raise InputError(f"unknown model {name!r}; known: {sorted(MODELS)}", key=key) from None


def custom_model(names, *, transport_from_estimate=True, key="states"):
    """A model over any known state names (see :data:`inins.core.error_model.GROUPS`)."""
    try:
        layout = StateLayout(tuple(names))
    except ValueError as exc:
        raise InputError(str(exc), key=key) from None
    return Model("custom", layout, transport_from_estimate)
