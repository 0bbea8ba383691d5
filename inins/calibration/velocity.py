"""Velocity-error method (000 §2, eqs. 10-12): quadratic fit of the velocity error per hold.

At rest the computed velocity is the velocity error. With the phi angle (NED),
``d dv/dt = f_n x phi + mat_nb df`` and ``f_n = [0, 0, -g]``, so
``d dv_N/dt = g phi_E + df_N`` and ``d dv_E/dt = -g phi_N + df_E``. Over a hold the
tilt drifts linearly, so ``dv(t) = a + b t + c t^2`` with ``c_N = g dphi_E/dt / 2`` and
``c_E = -g dphi_N/dt / 2`` (000 eq. 12: the second-order coefficient). A constant
accelerometer bias only enters the linear term; a bias that changes during the hold
(000 Fig. 2: after a rotation) bends the curve and biases the estimate.

Noise: with angle random walk N the tilt is a Wiener process, whose integral
``X(t)`` has ``Cov(X(t), X(u)) = N^2 (t^2 u / 2 - t^3 / 6)`` for ``t <= u``; velocity
random walk V adds ``V^2 min(t, u)``, velocity quantization q adds ``q^2 / 12``
per sample. The variance of the fitted ``c`` is ``L K L^T`` with L the row of the
least-squares solution.
"""

from dataclasses import dataclass

import numpy as np

from inins.core import earth

MAX_FIT_POINTS = 1000


@dataclass(frozen=True)
class HoldFit:
    """Tilt rate of one hold from the velocity curvature.

    Attributes
    ----------
    phi_rate_n : ndarray, shape (3,)
        ``d phi / dt`` (rad/s, NED; the down component is not observed and is 0).
    sigma : float
        1-sigma of each horizontal component of ``phi_rate_n`` (rad/s).
    mat_bn : ndarray, shape (3, 3)
        Attitude at mid-hold.
    points : ndarray of int
        Track samples used in the fit.
    curvature_row : ndarray
        Least-squares row giving the ``t^2`` coefficient from the fitted samples.
    """

    phi_rate_n: np.ndarray
    sigma: float
    mat_bn: np.ndarray
    points: np.ndarray
    curvature_row: np.ndarray


def _design(tau):
    return np.stack([np.ones_like(tau), tau, tau * tau], axis=1)


def _noise_covariance(tau, arw, vrw, quantum, g):
    t, u = np.minimum.outer(tau, tau), np.maximum.outer(tau, tau)
    cov = (g * arw) ** 2 * (t * t * u / 2.0 - t**3 / 6.0) + vrw**2 * t
    return cov + np.eye(tau.size) * quantum**2 / 12.0


def fit_hold(track, window, arw=0.0, vrw=0.0, quantum=0.0):
    """Quadratic fit of the velocity error over a hold window (s, s).

    Parameters
    ----------
    track : inins.calibration.tilt_model.Track
    window : (float, float)
    arw, vrw, quantum : float
        Angle random walk (rad/sqrt(s)), velocity random walk (m/s/sqrt(s)) and
        velocity pulse weight (m/s) for the 1-sigma (isotropic figures).

    Returns
    -------
    HoldFit
    """
    inside = np.flatnonzero((track.time >= window[0] - 1e-9) & (track.time <= window[1] + 1e-9))
    if inside.size < 10:
        raise ValueError(f"too few navigation outputs in {window[0]:g}-{window[1]:g} s")
    inside = inside[
        np.unique(np.linspace(0, inside.size - 1, min(inside.size, MAX_FIT_POINTS)).astype(int))
    ]
    tau = track.time[inside] - track.time[inside[0]]
    design = _design(tau)
    solver = np.linalg.pinv(design)  # (3, p); row 2 gives the t^2 coefficient
    curvature = solver[2] @ track.vel_n[inside, :2]
    g = earth.gravity(track.lat, 0.0)
    phi_rate = np.array([-2.0 * curvature[1] / g, 2.0 * curvature[0] / g, 0.0])
    var_c = solver[2] @ _noise_covariance(tau, arw, vrw, quantum, g) @ solver[2]
    mid = inside[inside.size // 2]
    return HoldFit(phi_rate, 2.0 * np.sqrt(var_c) / g, track.mat_nb[mid].T, inside, solver[2])


def tilt_rate(fit, horizontal):
    """Body tilt rate ``-(mat_bn dphi/dt)_h`` (rad/s) of a fit, shape (2,)."""
    return -(fit.mat_bn @ fit.phi_rate_n)[horizontal]


def fit_gain(track, fit, horizontal, phi_response):
    """Response of the fitted tilt rate to the unknowns of the linear error model.

    With ``phi(t) = sum_u phi_response[t, :, u] x_u`` (:mod:`inins.calibration.tilt_model`),
    ``dv_N = g int phi_E`` and ``dv_E = -g int phi_N`` from the first fitted sample,
    so the fitted ``dphi/dt = 2 L int phi`` and the body tilt rate is
    ``-(mat_bn dphi/dt)_h``.

    Parameters
    ----------
    phi_response : ndarray, shape (m, 3, u)
        phi per unit of each unknown on the track grid.

    Returns
    -------
    ndarray, shape (2, u)
    """
    k0, k1 = fit.points[0], fit.points[-1] + 1
    seg = phi_response[k0:k1]
    dt = np.diff(track.time[k0:k1])[:, None, None]
    integral = np.concatenate(
        [np.zeros((1, *seg.shape[1:])), np.cumsum(0.5 * (seg[1:] + seg[:-1]) * dt, axis=0)]
    )
    phi_rate = 2.0 * np.einsum("p,pru->ru", fit.curvature_row, integral[fit.points - k0])
    phi_rate[2] = 0.0  # the vertical is not observed
    return -(fit.mat_bn @ phi_rate)[horizontal]
