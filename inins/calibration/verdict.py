"""What a calibration method's own information matrix says: which terms the schedule
separates, their 1-sigma, and the combinations it leaves free (named, never shown with
a sigma of 0).

Every method of calibrate-imu (discrete, table-free, system-level) builds the
information matrix of its own measurements ``I = J^T W J`` (the system-level filter:
its posterior precision less its prior's), and this module decides from it. With each
term scaled to a typical size ``s`` (``I_s = S I S``, ``S = diag(s)``), the rank decides
first: an eigen-direction of ``I_s`` whose eigenvalue is at or below ``rel_tol`` times
the largest is in the null space, and a term with any weight on it is not separable.
Then the sigma: a term whose variance from the other directions exceeds its typical size
squared over ``min_information`` is not determined either (a weak direction, such as
a scale factor that only the Earth rate reaches). Either way its sigma is ``inf`` and the
direction is named as a combination of terms (SI coefficients, the largest 1). The
covariance of the separable terms is the inverse of ``I_s`` on the resolved directions
(NaN rows and columns for the others).
"""

from dataclasses import dataclass

import numpy as np

REL_TOL = 1e-10
"""Eigenvalue of the scaled information, relative to the largest, below which a
direction is in the null space (a singular value 1e-5 of the largest)."""
WEIGHT_TOL = 1e-8
"""A term whose squared weight on the unresolved directions (unit eigenvectors of the
scaled information) exceeds this is not separable."""


TYPICAL = {
    "ba": 1e-3,  # m/s^2, 100 ug
    "bg": 1e-5,  # rad/s, 2 deg/h
    "sa": 1e-4,  # 100 ppm
    "sg": 1e-4,
    "ma": 1e-4,  # rad, 21 arcsec
    "mg": 1e-4,
    "gg": 1e-6,  # rad/s per m/s^2, 2 deg/h per g
    "mo": 1e-3,  # mount, rad
}
"""Typical size of each kind of term (SI, by the first two letters of its name): the
units the eigen-analysis is done in, so that a combination of a gyro bias and a heading
(one Earth rate times the other) weighs what it means."""


def typical_scale(names):
    """:data:`TYPICAL` size of each term of ``names``, shape (p,)."""
    return np.array([TYPICAL[n[:2]] for n in names])


@dataclass(frozen=True)
class Verdict:
    """What a schedule (or a fit's data) gives.

    Attributes
    ----------
    names : tuple of str
        The terms.
    sigma : ndarray, shape (p,)
        1-sigma (SI); ``inf`` for a term the data do not separate.
    separable : ndarray of bool, shape (p,)
    combinations : list of dict
        Each unresolved direction as ``{term: coefficient}`` (SI, largest coefficient
        1): the data fix nothing (or too little) along it.
    information : ndarray, shape (p, p)
    covariance : ndarray, shape (p, p)
        Inverse of the information on the resolved directions (NaN rows and columns
        for the terms that are not separable).
    rank : int
        Number of resolved directions.
    """

    names: tuple
    sigma: np.ndarray
    separable: np.ndarray
    combinations: list
    information: np.ndarray
    covariance: np.ndarray
    rank: int = -1

    @property
    def inseparable(self):
        """Names of the terms that are not separable."""
        return tuple(n for n, ok in zip(self.names, self.separable, strict=True) if not ok)


def from_information(info, names, scale, rel_tol=REL_TOL, min_information=0.0, abs_tol=0.0):
    """The :class:`Verdict` of an information matrix.

    Parameters
    ----------
    info : ndarray, shape (p, p)
        Information of the terms (SI: inverse covariance).
    names : sequence of str
    scale : ndarray, shape (p,)
        Typical size of each term (SI), to make the eigen-analysis unit-free.
    rel_tol, abs_tol : float
        Rank tolerance: a scaled eigenvalue at or below ``rel_tol`` times the largest, or
        below ``abs_tol``, is in the null space; a term with any weight on it (squared,
        above :data:`WEIGHT_TOL`) is not separable.
    min_information : float
        The sigma criterion: a term whose scaled variance (its variance over its typical
        size squared, from the information on the other directions) exceeds
        ``1 / min_information`` is not determined either; the weak directions (scaled
        eigenvalue below it) that carry such terms are named beside the null space.
    """
    names = tuple(names)
    scale = np.asarray(scale, float)
    info = np.asarray(info, float)
    scaled = info * np.outer(scale, scale)
    evals, evecs = np.linalg.eigh(0.5 * (scaled + scaled.T))
    top = max(float(evals.max()) if evals.size else 0.0, 1e-300)
    null = (evals <= rel_tol * top) | (evals <= abs_tol)
    basis = evecs[:, null]
    weight = (basis**2).sum(axis=1) if basis.size else np.zeros(len(names))
    keep = ~null
    cov_scaled = (evecs[:, keep] / evals[keep]) @ evecs[:, keep].T
    var = np.clip(np.diag(cov_scaled), 0.0, None)
    separable = weight <= WEIGHT_TOL
    named = basis
    if min_information > 0.0:
        separable &= var <= 1.0 / min_information
        weak = keep & (evals < min_information)
        carries = (evecs[:, weak] ** 2)[~separable].sum(axis=0) > 0.5 / max(1, (~separable).sum())
        named = np.hstack([basis, evecs[:, weak][:, carries]])
    cov = cov_scaled * np.outer(scale, scale)
    cov[~separable, :] = np.nan
    cov[:, ~separable] = np.nan
    sigma = np.sqrt(var) * scale
    sigma[~separable] = np.inf
    combos = combinations(named, names, scale)
    return Verdict(names, sigma, separable, combos, info, cov, int(keep.sum()))


def combinations(basis, names, scale):
    """Unresolved directions (columns of ``basis``, scaled coordinates) as
    ``{term: SI coefficient}``, the largest 1 (terms whose scaled weight is below 1e-3 of
    the largest left out)."""
    out = []
    for v in np.asarray(basis).T:
        keep = np.abs(v) > 1e-3 * np.abs(v).max()
        v = v * scale
        v = v / v[np.argmax(np.abs(v))]
        out.append({n: float(c) for n, c, k in zip(names, v, keep, strict=True) if k})
    return out


def merge(*verdicts):
    """One verdict of independent blocks (block-diagonal information)."""
    names = sum((tuple(v.names) for v in verdicts), ())
    p = len(names)
    info, cov = np.zeros((p, p)), np.zeros((p, p))
    k = 0
    for v in verdicts:
        q = len(v.names)
        info[k : k + q, k : k + q] = v.information
        cov[k : k + q, k : k + q] = v.covariance
        k += q
    return Verdict(
        names,
        np.concatenate([v.sigma for v in verdicts]),
        np.concatenate([v.separable for v in verdicts]),
        [c for v in verdicts for c in v.combinations],
        info,
        cov,
        sum(v.rank for v in verdicts),
    )
