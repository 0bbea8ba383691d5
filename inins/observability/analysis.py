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
    """

    name: str
    unit: str
    observable: bool
    null_weight: float
    sigma_0: float
    sigma_final: float
    sigma_ratio: float


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
    states = tuple(
        StateSummary(name, unit, obs, float(w), float(a), float(b), float(c))
        for name, unit, obs, w, a, b, c in zip(
            structure.names,
            structure.units,
            structure.observable,
            structure.null_weight,
            s0,
            s1,
            ratio,
            strict=True,
        )
    )
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
    )
