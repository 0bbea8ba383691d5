"""One call for the ``observability`` command: PWCS rank and null space, Gramian
cross-check and covariance analysis, with a per-state summary.
"""

from dataclasses import dataclass

import numpy as np

from inins.observability import covariance, pwcs


@dataclass(frozen=True)
class StateSummary:
    """One state's verdict.

    Attributes
    ----------
    name, unit : str
    observable : bool
        From the PWCS null space (orthogonal to every unobservable direction).
    null_weight : float
        Norm of the state's row in the orthonormal scaled null basis.
    sigma_0, sigma_final : float
        1-sigma before and after the covariance analysis (SI); NaN without it.
    sigma_ratio : float
        ``sigma_final / sigma_0``; NaN without a covariance analysis.
    practical_after_s : float
        Time (s) from which ``sigma / sigma_0`` stays at or below
        :data:`PRACTICAL_RATIO`; NaN if it never does (or without a covariance
        analysis).
    """

    name: str
    unit: str
    observable: bool
    null_weight: float
    sigma_0: float
    sigma_final: float
    sigma_ratio: float
    practical_after_s: float = np.nan

    @property
    def degree(self) -> str:
        """The degree of observability in words: ``"unobservable"`` (in the null
        space: its sigma can only shrink through the priors of the states it is paired
        with), else ``"good"`` (sigma down to :data:`PRACTICAL_RATIO` of the prior or
        below), ``"weak"`` (reduced, not that far), ``"none"`` (within
        :data:`NEAR_PRIOR` of the prior: observable in rank, hardly estimated at all),
        ``"n/a"`` without a covariance analysis."""
        if not self.observable:
            return "unobservable"
        if not np.isfinite(self.sigma_ratio):
            return "n/a"
        if self.sigma_ratio <= PRACTICAL_RATIO:
            return "good"
        return "none" if self.sigma_ratio >= NEAR_PRIOR else "weak"


PRACTICAL_RATIO = 0.1
"""A state is observable in practice when its 1-sigma has come down to a tenth of its
prior (and stays there): the measurements, not the prior, then set the estimate."""
NEAR_PRIOR = 0.9
"""A sigma ratio above this is "near 1": the state is hardly estimated at all."""


def practical_times(time, sigma, threshold=PRACTICAL_RATIO):
    """Per state, the first time from which ``sigma / sigma[0]`` stays ``<= threshold``.

    Parameters
    ----------
    time : ndarray, shape (K,)
    sigma : ndarray, shape (K, n)
        1-sigma history, row 0 the prior.
    threshold : float

    Returns
    -------
    ndarray, shape (n,)
        Time (s) per state; NaN where the ratio ends above ``threshold``.
    """
    ratio = sigma / sigma[0]
    above = ratio > threshold
    out = np.full(sigma.shape[1], np.nan)
    for i in range(sigma.shape[1]):
        rows = np.flatnonzero(above[:, i])
        last = rows[-1] if rows.size else -1
        if last < len(time) - 1:
            out[i] = time[last + 1]
    return out


@dataclass(frozen=True)
class ObservabilityReport:
    """Everything :func:`analyse` found.

    Attributes
    ----------
    model : str
    rank, n_states, n_unobservable : int
        From the PWCS analysis.
    gramian_rank : int
        Rank of the observability Gramian along the same segments.
    pwcs : PwcsResult
    covariance : CovarianceResult or None
    states : tuple of StateSummary
    warnings : tuple of str
        The total matrix was needed (stripping condition failed on some
        segments), or the Gramian rank disagrees with the PWCS rank.
    practically_observable_after_s : float or None
        Time from which every state stays at or below :data:`PRACTICAL_RATIO` of its
        prior (:func:`practical_times`); None if some state never gets there or
        without a covariance analysis. The rank says what can be estimated at all,
        this says when the estimate is set by the measurements.
    """

    model: str
    rank: int
    n_states: int
    n_unobservable: int
    gramian_rank: int
    pwcs: pwcs.PwcsResult
    covariance: covariance.CovarianceResult | None
    states: tuple
    warnings: tuple = ()
    practically_observable_after_s: float | None = None

    @property
    def poorly_observable(self):
        """Names of the rank-observable states whose sigma stays above
        :data:`PRACTICAL_RATIO` of the prior (empty without a covariance analysis)."""
        return tuple(s.name for s in self.states if s.degree in ("weak", "none"))

    @property
    def combinations(self):
        """Unobservable directions written out (see :class:`PwcsResult`)."""
        return self.pwcs.combinations

    def state(self, name):
        """The :class:`StateSummary` of ``name``."""
        for s in self.states:
            if s.name == name:
                return s
        raise KeyError(name)


def analyse(
    model, segments, measurements, *, sigma_0=None, noise=None, dt=1.0, scales=None, method="auto"
):
    """Observability of ``model`` along ``segments`` with ``measurements``.

    Parameters
    ----------
    model : Model
    segments : sequence of Segment
    measurements : sequence of Measurement
    sigma_0 : array_like, shape (n,), optional
        Initial 1-sigma per state (SI). None skips the covariance analysis.
    noise : ProcessNoise, optional
    dt : float
        Measurement interval of the covariance analysis (s).
    scales : array_like, shape (n,), optional
        State scales of the PWCS analysis (default SI units).
    method : {"auto", "stripped", "total"}

    Returns
    -------
    ObservabilityReport
    """
    structure = pwcs.analyse(model, segments, measurements, scales=scales, method=method)
    w_rank = pwcs.gramian_rank(model, segments, measurements, scales=scales)
    cov = None
    if sigma_0 is not None:
        cov = covariance.analyse(model, segments, measurements, sigma_0, noise=noise, dt=dt)
    nan = np.full(structure.n_states, np.nan)
    s0, s1, ratio = (
        (nan, nan, nan) if cov is None else (cov.sigma_0, cov.sigma_final, cov.sigma_ratio)
    )
    practical = nan if cov is None else practical_times(cov.time, cov.sigma)
    states = tuple(
        StateSummary(name, unit, obs, float(w), float(a), float(b), float(c), float(t))
        for name, unit, obs, w, a, b, c, t in zip(
            structure.names,
            structure.units,
            structure.observable,
            structure.null_weight,
            s0,
            s1,
            ratio,
            practical,
            strict=True,
        )
    )
    all_practical = None
    if cov is not None and np.all(np.isfinite(practical)):
        all_practical = float(practical.max())
    warnings = []
    failed = [j for j, ok in enumerate(structure.condition_holds) if not ok]
    if failed and structure.method == "total":
        warnings.append(
            f"null(Q_j) is not inside null(F_j) on segments {failed}: the total "
            "observability matrix was used"
        )
    if w_rank != structure.rank:
        warnings.append(
            f"the Gramian rank {w_rank} differs from the PWCS rank {structure.rank}: "
            "the weakest directions are near the numerical tolerance"
        )
    return ObservabilityReport(
        model.name,
        structure.rank,
        structure.n_states,
        structure.n_unobservable,
        w_rank,
        structure,
        cov,
        states,
        tuple(warnings),
        all_practical,
    )
