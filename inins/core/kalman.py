"""Linear Kalman filter numerics: discretisation, prediction, Joseph-form update,
innovation gating and consistency statistics (NEES, NIS).

Pure functions on numpy arrays; the maths symbols are kept: ``F`` continuous
system matrix, ``Qc`` continuous process-noise density, ``Phi`` transition
matrix, ``Qd`` discrete process noise, ``P`` covariance, ``H`` measurement
matrix, ``R`` measurement noise covariance. Covariances are returned
symmetrised. Inverses are never formed: every ``S^-1 b`` is a Cholesky solve.

References: C. F. Van Loan, "Computing integrals involving the matrix
exponential", IEEE TAC 23(3), 1978; Bar-Shalom, Li, Kirubarajan, *Estimation
with Applications to Tracking and Navigation*, 2001, §5.4 (consistency).
"""

import numpy as np
from scipy import linalg

from inins.core.stats import chi2_ppf


def _sym(P):
    return 0.5 * (P + np.swapaxes(P, -1, -2))


def discretize(F, Qc, dt, method="van_loan"):
    """Discrete transition matrix and process noise of ``x' = F x + w``.

    ``Phi = expm(F dt)``, ``Qd = int_0^dt expm(F s) Qc expm(F s)^T ds`` with
    ``E[w(t) w(s)^T] = Qc delta(t - s)``.

    Parameters
    ----------
    F, Qc : array_like, shape (..., n, n)
    dt : float
        Step (s).
    method : {"van_loan", "first_order"}
        ``"van_loan"`` is exact for constant ``F``, ``Qc``: with
        ``B = expm([[-F, Qc], [0, F^T]] dt) = [[., B12], [0, B22]]``,
        ``Phi = B22^T`` and ``Qd = Phi B12``. ``"first_order"`` takes
        ``Phi = I + F dt``, ``Qd = Qc dt``, both with error O(dt^2).

    Returns
    -------
    Phi, Qd : ndarray, shape (..., n, n)
    """
    F = np.asarray(F, dtype=float)
    Qc = np.broadcast_to(np.asarray(Qc, dtype=float), F.shape)
    n = F.shape[-1]
    if method == "first_order":
        return np.eye(n) + F * dt, _sym(Qc * dt)
    if method != "van_loan":
        raise ValueError(f"method must be 'van_loan' or 'first_order', got {method!r}")
    A = np.zeros((*F.shape[:-2], 2 * n, 2 * n))
    A[..., :n, :n] = -F
    A[..., :n, n:] = Qc
    A[..., n:, n:] = np.swapaxes(F, -1, -2)
    B = linalg.expm(A * dt)
    Phi = np.swapaxes(B[..., n:, n:], -1, -2)
    return Phi, _sym(Phi @ B[..., :n, n:])


def predict(x, P, Phi, Qd):
    """Time update: ``x = Phi x``, ``P = Phi P Phi^T + Qd``.

    Parameters
    ----------
    x : array_like, shape (n,)
    P, Phi, Qd : array_like, shape (n, n)

    Returns
    -------
    x, P : ndarray, shapes (n,), (n, n)
    """
    Phi = np.asarray(Phi, dtype=float)
    return Phi @ np.asarray(x, dtype=float), _sym(Phi @ np.asarray(P, dtype=float) @ Phi.T + Qd)


def update(x, P, z, H, R):
    """Measurement update in Joseph form.

    ``y = z - H x``, ``S = H P H^T + R``, ``K = P H^T S^-1`` (Cholesky solve),
    ``x+ = x + K y``, ``P+ = (I - K H) P (I - K H)^T + K R K^T``. The Joseph form
    keeps ``P+`` symmetric positive definite under rounding and for any gain.

    Parameters
    ----------
    x : array_like, shape (n,)
    P : array_like, shape (n, n)
    z : array_like, shape (m,)
    H : array_like, shape (m, n)
    R : array_like, shape (m, m)

    Returns
    -------
    x, P : ndarray, shapes (n,), (n, n)
        Posterior state and covariance.
    y, S : ndarray, shapes (m,), (m, m)
        Innovation and its covariance (for :func:`nis` and :func:`gate`).

    Raises
    ------
    numpy.linalg.LinAlgError
        If ``S`` is not positive definite.
    """
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    H = np.atleast_2d(np.asarray(H, dtype=float))
    R = np.atleast_2d(np.asarray(R, dtype=float))
    y = np.atleast_1d(np.asarray(z, dtype=float)) - H @ x
    PHt = P @ H.T
    S = _sym(H @ PHt + R)
    K = linalg.cho_solve(linalg.cho_factor(S), PHt.T).T
    A = np.eye(len(x)) - K @ H
    return x + K @ y, _sym(A @ P @ A.T + K @ R @ K.T), y, S


def _mahalanobis(e, P):
    """``e^T P^-1 e`` by Cholesky, for stacks (..., k) and (..., k, k)."""
    e = np.asarray(e, dtype=float)
    L = np.linalg.cholesky(np.asarray(P, dtype=float))
    w = np.linalg.solve(L, e[..., None])[..., 0]
    return np.sum(w * w, axis=-1)


def nis(y, S):
    """Normalised innovation squared ``y^T S^-1 y``; chi-square with ``m`` dof if consistent.

    Parameters
    ----------
    y : array_like, shape (..., m)
    S : array_like, shape (..., m, m)

    Returns
    -------
    float or ndarray, shape (...)
    """
    return _mahalanobis(y, S)


def nees(e, P):
    """Normalised estimation error squared ``e^T P^-1 e`` (``e`` = estimate - truth).

    Chi-square with ``n`` degrees of freedom for a consistent filter.

    Parameters
    ----------
    e : array_like, shape (..., n)
    P : array_like, shape (..., n, n)

    Returns
    -------
    float or ndarray, shape (...)
    """
    return _mahalanobis(e, P)


def gate(y, S, probability=0.9973):
    """Chi-square innovation gate.

    Accept when ``y^T S^-1 y <= chi2.ppf(probability, m)``: a consistent filter
    rejects a fraction ``1 - probability`` of good measurements.

    Parameters
    ----------
    y : array_like, shape (m,)
    S : array_like, shape (m, m)
    probability : float
        Gate probability (0.9973 is the 3-sigma equivalent).

    Returns
    -------
    accepted : bool
    value : float
        The NIS of ``y``.
    """
    y = np.atleast_1d(np.asarray(y, dtype=float))
    value = float(nis(y, np.atleast_2d(S)))
    return bool(value <= chi2_ppf(probability, y.shape[-1])), value


def consistency_bounds(dim, count, probability=0.95):
    """Two-sided bounds on the average of ``count`` independent chi-square(dim) statistics.

    For a consistent filter ``count * mean(NIS)`` is chi-square with
    ``count * dim`` degrees of freedom, so the mean lies in the returned
    interval with the given probability (Bar-Shalom et al. §5.4.2).

    Returns
    -------
    low, high : float
    """
    dof = dim * count
    tail = 0.5 * (1.0 - probability)
    return (chi2_ppf(tail, dof) / count, chi2_ppf(1.0 - tail, dof) / count)
