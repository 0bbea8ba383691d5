"""Statistics of a sweep's results: over all points and per value of each axis (a
grid key, or the first key of a zip group).

For each group of points and each chosen result: the count of points with a
value, mean, sample standard deviation (ddof = 1), percentiles, min and max; the
pass rate of the checks (share of the group's points whose checks all passed; a
point that raised counts as not passed) and the number of errors.

Where a result ``X_<unit>`` comes with its reported 1-sigma ``X_sigma_<unit>``
(calibrate-bias: ``beta_x_dph`` and ``beta_x_sigma_dph``), the group also gets
the Monte Carlo consistency figure: the sample std of ``X`` against the RMS of
its reported sigma (ratio ~1 when the reported 1-sigma is right; for n points the
ratio's own spread is about 1/sqrt(2(n-1))).
"""

from dataclasses import dataclass

import numpy as np

from inins.exceptions import InputError


@dataclass(frozen=True)
class ResultStats:
    """Statistics of one result over one group (units of the result)."""

    group: str
    value: str
    result: str
    n: int
    mean: float
    std: float
    percentiles: tuple
    min: float
    max: float


@dataclass(frozen=True)
class GroupRate:
    """Pass rate of one group of points."""

    group: str
    value: str
    points: int
    passed: int
    errors: int

    @property
    def pass_rate(self) -> float:
        """Share of the points whose checks all passed (0..1)."""
        return self.passed / self.points if self.points else float("nan")


@dataclass(frozen=True)
class SigmaConsistency:
    """Sample std of a result against the RMS of its reported 1-sigma."""

    group: str
    value: str
    result: str
    n: int
    sample_std: float
    reported_sigma: float

    @property
    def ratio(self) -> float:
        """sample_std / reported_sigma."""
        return self.sample_std / self.reported_sigma if self.reported_sigma else float("nan")


@dataclass(frozen=True)
class Aggregates:
    """All statistics of a sweep."""

    percentiles: tuple
    stats: tuple
    rates: tuple
    sigmas: tuple


def sigma_name(name: str) -> str:
    """``beta_x_dph`` -> ``beta_x_sigma_dph`` (the reported 1-sigma's name)."""
    stem, _, unit = name.rpartition("_")
    return f"{stem}_sigma_{unit}" if stem else f"{name}_sigma"


def chosen_results(table, names) -> list:
    """The results to summarise; :class:`InputError` for a name no point produced."""
    if names is None:
        sigmas = {sigma_name(n) for n in table.result_names}
        return [
            n for n in table.result_names if n not in sigmas and np.isfinite(table.result(n)).any()
        ]
    unknown = [n for n in names if n not in table.result_names]
    if unknown and table.result_names:
        raise InputError(
            f"unknown result {unknown[0]!r} (results: {', '.join(table.result_names)})",
            key="aggregate.results",
        )
    return [n for n in names if n in table.result_names]


def aggregate(table, names=None, percentiles=(5.0, 50.0, 95.0)) -> Aggregates:
    """Statistics over all points (group ``all``) and per value of every swept key.

    Parameters
    ----------
    table : inins.sweep.table.SweepTable
    names : list of str, optional
        Results to summarise; default every result with a number somewhere, except
        the reported 1-sigmas (which go into the consistency table).
    percentiles : sequence of float
        In [0, 100].
    """
    names = chosen_results(table, names)
    columns = {n: table.result(n) for n in names}
    sigmas = {n: table.result(sigma_name(n)) for n in names if sigma_name(n) in table.result_names}
    passed = np.array([r["status"] == "passed" for r in table.records], dtype=bool)
    errors = np.array([r["status"] == "error" for r in table.records], dtype=bool)
    groups = [("all", "", np.ones(len(table.records), dtype=bool))]
    for key in table.group_keys or table.axis_keys:
        values = [_label(v) for v in table.axis(key)]
        for label in dict.fromkeys(values):
            groups.append((key, label, np.array([v == label for v in values], dtype=bool)))
    stats, rates, consistency = [], [], []
    for group, label, mask in groups:
        rates.append(
            GroupRate(
                group, label, int(mask.sum()), int(passed[mask].sum()), int(errors[mask].sum())
            )
        )
        for name, column in columns.items():
            stats.append(_stats(group, label, name, column[mask], percentiles))
            if name in sigmas:
                consistency.append(
                    _consistency(group, label, name, column[mask], sigmas[name][mask])
                )
    return Aggregates(tuple(percentiles), tuple(stats), tuple(rates), tuple(consistency))


def _label(value) -> str:
    if isinstance(value, float) and value == int(value) and abs(value) < 1e15:
        return repr(value)
    return str(value)


def _stats(group, label, name, column, percentiles) -> ResultStats:
    x = column[np.isfinite(column)]
    if x.size == 0:
        nan = float("nan")
        return ResultStats(group, label, name, 0, nan, nan, (nan,) * len(percentiles), nan, nan)
    std = float(np.std(x, ddof=1)) if x.size > 1 else float("nan")
    pct = tuple(float(p) for p in np.percentile(x, percentiles)) if percentiles else ()
    return ResultStats(
        group, label, name, int(x.size), float(np.mean(x)), std, pct, float(x.min()), float(x.max())
    )


def _consistency(group, label, name, column, sigma) -> SigmaConsistency:
    ok = np.isfinite(column) & np.isfinite(sigma)
    x, s = column[ok], sigma[ok]
    std = float(np.std(x, ddof=1)) if x.size > 1 else float("nan")
    rms = float(np.sqrt(np.mean(s**2))) if s.size else float("nan")
    return SigmaConsistency(group, label, name, int(x.size), std, rms)


def stats_columns(aggs: Aggregates) -> dict:
    """``{column: values}`` of the statistics table (``aggregates.csv``)."""
    cols = {k: [] for k in ("group", "value", "result", "n", "mean", "std")}
    pct_names = [f"p{p:g}" for p in aggs.percentiles]
    for p in pct_names:
        cols[p] = []
    cols["min"], cols["max"] = [], []
    for s in aggs.stats:
        for k in ("group", "value", "result", "n", "mean", "std", "min", "max"):
            cols[k].append(getattr(s, k))
        for p, v in zip(pct_names, s.percentiles, strict=True):
            cols[p].append(v)
    return cols


def format_aggregates(aggs: Aggregates, overall_only: bool = False) -> str:
    """Plain-text tables of the statistics, pass rates and sigma consistency
    (``overall_only``: the statistics of group ``all`` only, pass rates of all groups)."""
    from inins.results import format_table

    if overall_only:
        aggs = Aggregates(
            aggs.percentiles,
            tuple(s for s in aggs.stats if s.group == "all"),
            aggs.rates,
            tuple(c for c in aggs.sigmas if c.group == "all"),
        )

    pct = [f"p{p:g}" for p in aggs.percentiles]
    rows = [
        [s.group, s.value, s.result, s.n, s.mean, s.std, *s.percentiles, s.min, s.max]
        for s in aggs.stats
    ]
    head = ["group", "value", "result", "n", "mean", "std", *pct, "min", "max"]
    parts = ["Results", format_table(rows, head, indent=2)] if rows else []
    rates = [[r.group, r.value, r.points, r.passed, r.errors, r.pass_rate] for r in aggs.rates]
    parts += [
        "Checks",
        format_table(
            rates, ["group", "value", "points", "passed", "errors", "pass rate"], indent=2
        ),
    ]
    if aggs.sigmas:
        rows = [
            [c.group, c.value, c.result, c.n, c.sample_std, c.reported_sigma, c.ratio]
            for c in aggs.sigmas
        ]
        head = ["group", "value", "result", "n", "sample std", "reported 1-sigma (rms)", "ratio"]
        parts += ["Sample std against reported 1-sigma", format_table(rows, head, indent=2)]
    return "\n".join(parts)
