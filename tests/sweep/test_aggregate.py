"""Per-axis statistics of a sweep table, against numpy on known numbers."""

import math

import numpy as np
import pytest

from inins.exceptions import InputError
from inins.sweep.aggregate import aggregate, format_aggregates, sigma_name
from inins.sweep.table import SweepTable


def _table():
    rng = np.random.default_rng(4)
    x = rng.normal(0.0, 2.0, 40)
    records = [
        {
            "status": "passed" if i % 4 else "check-failed",
            "results": {"beta_dph": float(x[i]), "beta_sigma_dph": 2.0, "n": None},
            "truth": {},
            "checks": [["abs(beta_dph) < 9", i % 4 != 0]],
            "seed": i,
        }
        for i in range(40)
    ]
    records[5] = {**records[5], "status": "error", "results": {}, "checks": []}
    axis = [(float(i % 2),) for i in range(40)]
    names = ["beta_dph", "beta_sigma_dph", "n"]
    return x, SweepTable(
        [str(i) for i in range(40)], ("k",), axis, records, names, [], ["abs(beta_dph) < 9"]
    )


def test_statistics_match_numpy_per_group():
    x, table = _table()
    aggs = aggregate(table, None, (10.0, 90.0))
    kept = np.delete(x, 5)
    overall = next(s for s in aggs.stats if s.group == "all")
    assert overall.result == "beta_dph" and overall.n == 39
    assert overall.mean == pytest.approx(np.mean(kept), abs=1e-15)
    assert overall.std == pytest.approx(np.std(kept, ddof=1), abs=1e-15)
    assert overall.percentiles == pytest.approx(tuple(np.percentile(kept, [10, 90])), abs=1e-15)
    odd = next(s for s in aggs.stats if s.group == "k" and s.value == "1.0")
    odd_x = np.array([x[i] for i in range(1, 40, 2) if i != 5])
    assert odd.n == 19 and odd.mean == pytest.approx(odd_x.mean(), abs=1e-15)
    # sigma results are summarised through the consistency table only
    assert {s.result for s in aggs.stats} == {"beta_dph"}


def test_pass_rate_and_sigma_consistency():
    x, table = _table()
    aggs = aggregate(table)
    rate = next(r for r in aggs.rates if r.group == "all")
    # 10 points fail their check (i % 4 == 0), one raised (5): 29 of 40 passed
    assert (rate.points, rate.passed, rate.errors) == (40, 29, 1)
    assert rate.pass_rate == pytest.approx(29 / 40)
    sig = next(c for c in aggs.sigmas if c.group == "all")
    assert sig.reported_sigma == 2.0
    assert sig.ratio == pytest.approx(np.std(np.delete(x, 5), ddof=1) / 2.0, abs=1e-15)
    # 39 draws of N(0, 2): the ratio is 1 within a few times 1/sqrt(2 * 38)
    assert abs(sig.ratio - 1.0) < 3 / math.sqrt(76)
    text = format_aggregates(aggs, overall_only=True)
    assert "Sample std against reported 1-sigma" in text and "k  " not in text.split("Checks")[0]


def test_unknown_result_name_and_sigma_names():
    _, table = _table()
    with pytest.raises(InputError, match="unknown result 'beta'"):
        aggregate(table, ["beta"])
    assert sigma_name("beta_x_dph") == "beta_x_sigma_dph"
    assert sigma_name("mount_y_arcsec") == "mount_y_sigma_arcsec"
