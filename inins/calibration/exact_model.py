"""The tilt response to a gyro bias without linearising in the initial heading error.

Why. After gyrocompassing the initial heading error is ``phi_D0 ~ beta_E / (W cos lat)``
(000 §3.2): 4.8 deg for 1 deg/h at 37 deg. The linear model of :mod:`.tilt_model` drops
the products of that angle with the bias and the second-order Earth-rate terms, which
bias the east-axis formulas by ~ phi_D0 relative (-11.7 % at 1 deg/h, issue 7).

Model. With stationary navigation the local-level frame turns with the Earth,
``Omega(t) = exp([omega_ie_n x] (t - t0)) = Phi(t)^T``. Writing the attitude error as the
rotation ``E = mat_nb_est mat_nb_true^T`` (``E ~ I - [phi x]``), the bias integrates in
inertial space along the computed attitude, and (to first order in the bias angle, with
every power of the initial error kept)::

    E(t) = Omega(t)^T exp([h(t) x]) E0 Omega(t),  h(t) = int_t0^t Omega(s) mat_nb(s) b ds  (3)

Linearised, (3) is eq. (1) of :mod:`.tilt_model`. The tilt observable
``eps = (mat_nb_est^T e_D) x d0`` then changes, relative to the true level of the
position (``mat_nb_true^T e_D`` is constant during a hold), by exactly::

    eps(t) - const = (mat_nb_est(t)^T (e_D - E(t) e_D)) x d0                 (4)

The gyrocompass heading (:func:`inins.calibration.alignment.gyrocompass_heading`) nulls
the east component of the measured Earth rate in the computed frame,
``(E0 omega_ie_n)_E + (mat_nb_est(0) b)_E = 0``, so exactly (level alignment)::

    sin(phi_D0) = (mat_nb_est(0) b)_E / (W cos lat),   E0 = exp(-[phi_D0 e_D x])     (5)

:func:`refine` solves the formulas with (3)-(5) by a fixed-point iteration whose
linear operator is the exact linear gain; each step costs one evaluation of (3)-(4) on
the output grid (no new navigation and no new gains).
"""

from dataclasses import dataclass

import numpy as np

from inins.core import earth, rotation

MAX_ITERATIONS = 40
"""Fixed-point steps at most; each reduces the error by about sin(phi_D0) (< 0.5 where
gyrocompassing is accepted, :data:`MAX_SIN_HEADING`), so 40 reach the rounding level."""

MAX_SIN_HEADING = 0.5
"""Gyrocompassing is refused where the horizontal bias reaches half the horizontal Earth
rate (initial heading error 30 deg): the fixed point then contracts too slowly, the
heading noise ``ARW / (W cos lat sqrt(T))`` is large, and at the pole it has no solution."""

WARN_SIN_HEADING = 0.02
"""Above this (heading error 1.1 deg) the linear tilt model is off by ~2 %: a warning
says the estimates rest on the exact rotation model (:func:`refine`)."""

E_D = np.array([0.0, 0.0, 1.0])


def gyrocompass_heading_error(mat_nb0, bias, lat):
    """Initial heading error ``phi_D0`` (rad) of a gyrocompass alignment, eq. (5).

    Parameters
    ----------
    mat_nb0 : ndarray, shape (3, 3)
        Computed attitude at the alignment.
    bias : ndarray, shape (3,)
        Gyro bias (rad/s, b frame).
    lat : float
        Latitude (rad).

    Returns
    -------
    float
        NaN where ``|(mat_nb0 b)_E| >= W cos lat`` (no gyrocompass solution).
    """
    ratio = (np.asarray(mat_nb0) @ bias)[1] / (earth.RATE * np.cos(lat))
    return float(np.arcsin(ratio)) if abs(ratio) < 1.0 else float("nan")


@dataclass(frozen=True)
class ExactModel:
    """Arrays of (3)-(4) along the track, formed once.

    ``h_gain`` (m, 3, 3): ``int Omega mat_nb ds`` so that ``h = h_gain b``; ``phi_t``
    (m, 3, 3): ``Omega^T``; ``down_i`` (m, 3): ``Omega e_D``; ``mat_bn`` (m, 3, 3);
    ``d0`` (3,) the nominal body down axis; ``mat_nb0`` (3, 3); ``lat`` (rad).
    """

    h_gain: np.ndarray
    phi_t: np.ndarray
    down_i: np.ndarray
    mat_bn: np.ndarray
    d0: np.ndarray
    mat_nb0: np.ndarray
    lat: float

    @classmethod
    def of(cls, track, phi_t, phit_nb):
        """From the track and its ``Phi`` (m, 3, 3) and ``Phi^T mat_nb`` (m, 3, 3)."""
        dt = np.diff(track.time)[:, None, None]
        h_gain = np.concatenate(
            [np.zeros((1, 3, 3)), np.cumsum(0.5 * (phit_nb[1:] + phit_nb[:-1]) * dt, axis=0)]
        )
        return cls(
            h_gain,
            phi_t,
            phi_t[:, 2, :],  # Omega e_D = Phi^T e_D = third row of Phi
            np.swapaxes(track.mat_nb, 1, 2),
            track.d0,
            track.mat_nb[0],
            track.lat,
        )

    def tilts(self, bias, phi_d0, index=slice(None)):
        """Tilt change (rad) predicted by (3)-(4), shape (m, 3) (or of the samples ``index``).

        Parameters
        ----------
        bias : ndarray, shape (3,)
            Gyro bias (rad/s, b frame).
        phi_d0 : float
            Initial heading error (rad, phi angle about down).
        index : slice or ndarray of int, optional
            Output samples to evaluate.
        """
        e0 = rotation.mat_from_rotvec(np.array([0.0, 0.0, -phi_d0]))
        v = _rotate(self.h_gain[index] @ bias, self.down_i[index] @ e0.T)
        v = np.einsum("mij,mj->mi", self.phi_t[index], v)
        return np.cross(np.einsum("mij,mj->mi", self.mat_bn[index], E_D - v), self.d0)

    def evaluate(self, weights, bias, gyrocompass, index=None):
        """Formula values (k,) that (3)-(5) predict for ``weights`` (k, m, 3); only the
        samples in the epoch windows (nonzero weight, or ``index``) are evaluated, and
        ``weights`` may already be cut to ``index`` (k, len(index), 3)."""
        phi_d0 = gyrocompass_heading_error(self.mat_nb0, bias, self.lat) if gyrocompass else 0.0
        if not np.isfinite(phi_d0):
            return np.full(weights.shape[0], np.nan)
        if index is None:
            index = support(weights)
            weights = weights[:, index]
        return np.einsum("kmi,mi->k", weights, self.tilts(bias, phi_d0, index))


def support(weights):
    """Output samples (int array) where any of the formulas ``weights`` (k, m, 3) weighs."""
    return np.flatnonzero(np.any(weights != 0.0, axis=(0, 2)))


def _rotate(rotvec, vec):
    """``exp([rotvec x]) vec`` row by row (Rodrigues), each (m, 3)."""
    angle = np.linalg.norm(rotvec, axis=1, keepdims=True)
    small = angle < 1e-8
    safe = np.where(small, 1.0, angle)
    a = np.where(small, 1.0 - angle**2 / 6.0, np.sin(angle) / safe)
    b = np.where(small, 0.5 - angle**2 / 24.0, (1.0 - np.cos(angle)) / safe**2)
    cross = np.cross(rotvec, vec)
    return vec + a * cross + b * np.cross(rotvec, cross)


def refine(model, weights, s_bias, bias0, unknown, gyrocompass, tol=1e-12):
    """Solve ``values = N(b)`` (the formulas by (3)-(5)) for the unknown biases.

    Fixed point ``b <- b_lin - S_u^-1 (N(b) - S b)`` with the exact linear gain ``S``
    (``s_bias``, heading folded in) and ``b_lin`` its linear solution; contracts by about
    ``|phi_D0|`` per step.

    Parameters
    ----------
    model : ExactModel
    weights : ndarray, shape (k, m, 3)
        One formula per unknown axis.
    s_bias : ndarray, shape (k, 3)
    bias0 : ndarray, shape (3,)
        Linear solution ``S_u^-1 (values - S_k b_k)`` of the observed formula values,
        the other axes ``k`` taken as known (rad/s).
    unknown : list of int
        The k body axes solved for.
    gyrocompass : bool
        The initial heading error follows the bias by (5); else it is zero.

    Returns
    -------
    ndarray, shape (3,)
        The bias (rad/s); NaN if (5) has no solution.
    """
    inv = np.linalg.inv(s_bias[:, unknown])
    lin = np.asarray(bias0, float)
    b = lin.copy()
    index = support(weights)
    cut = weights[:, index]
    for _ in range(MAX_ITERATIONS):
        second = model.evaluate(cut, b, gyrocompass, index) - s_bias @ b
        new = b.copy()
        new[unknown] = lin[unknown] - inv @ second
        if not np.all(np.isfinite(new)):
            return np.full(3, np.nan)
        step = np.max(np.abs(new - b))
        b = new
        if step <= tol * max(np.max(np.abs(b)), 1e-12) or step < 1e-18:
            break
    return b


def jacobian(model, weights, bias, unknown, gyrocompass, rel_step=1e-3):
    """``d N / d b_u`` (k, k) of the formulas by (3)-(5) at ``bias`` (central differences),
    the gain through which noise in the formulas reaches the refined estimate."""
    index = support(weights)
    cut = weights[:, index]
    step = max(rel_step * float(np.max(np.abs(bias))), 1e-12)
    cols = []
    for axis in unknown:
        db = np.zeros(3)
        db[axis] = step
        plus = model.evaluate(cut, bias + db, gyrocompass, index)
        minus = model.evaluate(cut, bias - db, gyrocompass, index)
        cols.append((plus - minus) / (2.0 * step))
    return np.array(cols).T
