"""Degree of observability beside the rank: a state observable in rank whose sigma stays
near its prior is reported as such (summary, report, figure), and the time from which
every state is observable in practice is the time its sigma ratio stays below 0.1."""

import numpy as np
import pytest

from inins.commands import observability
from inins.observability.analysis import StateSummary, practical_times
from inins.scenario.observability import ObservabilityScenario
from tests.helpers import shipped


def test_practical_times_from_a_sigma_history():
    time = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    sigma = np.array(  # columns: down at 2 s for good; back above at the end; a dip
        [
            [1.0, 2.0, 1.0],
            [0.5, 0.1, 0.05],  # state 2 dips below 0.1 of its prior at 1 s ...
            [0.09, 0.2, 0.2],  # ... comes back above at 2 s, and stays below from 3 s
            [0.08, 0.2, 0.09],
            [0.05, 0.3, 0.08],  # state 1 ends at 0.15 of its prior: never
        ]
    )
    got = practical_times(time, sigma)
    np.testing.assert_array_equal(got[[0, 2]], [2.0, 3.0])
    assert np.isnan(got[1])


def test_degree_words():
    def state(observable, ratio):
        return StateSummary("x", "m", observable, 0.0, 1.0, ratio, ratio)

    assert state(True, 0.05).degree == "good"
    assert state(True, 0.5).degree == "weak"
    assert state(True, 0.97).degree == "none"
    assert state(False, 0.01).degree == "unobservable"
    assert state(True, np.nan).degree == "n/a"


@pytest.fixture(scope="module")
def bank_turns():
    scenario = shipped(ObservabilityScenario, "observability/ekf26-bank-turns.yaml")
    return observability.run(scenario, 0)


def test_full_rank_is_not_called_practically_observable(bank_turns):
    """EKF26 through six bank turns: full rank after 130 s, yet bg_z and ma_zy stay near
    their priors (ratios 0.98 and 1.00: the turns hardly excite them)."""
    r = bank_turns.results
    assert r["rank"] == 26 and r["full_rank_after_s"] == pytest.approx(130.0)
    assert r["practically_observable_after_s"] is None
    assert r["sigma_ratio_bg_z"] > 0.9 and r["sigma_ratio_ma_zy"] > 0.9
    assert r["n_poorly_observable"] == sum(
        1 for k, v in r.items() if k.startswith("sigma_ratio_") and v > 0.1
    )
    report = bank_turns.report
    assert "observable in practice (every sigma down to 0.1 of its prior): never" in report
    assert "bg_z: sigma end 0.978 of the prior - not estimated in practice" in report
    assert "ma_zy" in report.split("poorly observable")[1]


def test_practically_observable_time_when_every_sigma_comes_down():
    """002's manoeuvre (two headings, velocity and one baseline): full rank after the
    second segment (600 s), but bg_z ends at 0.11 of a 1 deg/h prior: never observable
    in practice. With a 10 deg/h prior the measurements set every state; the time is the
    first update from which every sigma ratio stays at or below 0.1."""
    base = shipped(ObservabilityScenario, "observability/default.yaml")
    r = observability.run(base, 0).results
    assert r["full_rank_after_s"] == pytest.approx(600.0)
    assert r["practically_observable_after_s"] is None and r["n_poorly_observable"] == 1
    assert 0.1 < r["sigma_ratio_bg_z"] < 0.2
    wide = shipped(
        ObservabilityScenario, "observability/default.yaml", **{"priors.gyro_bias_dph": 10.0}
    )
    found = observability.run(wide, 0)
    t = found.results["practically_observable_after_s"]
    assert t is not None and 0.0 < t <= 600.0 and found.results["n_poorly_observable"] == 0
    time = found.datasets["covariance/time"].data
    ratio = found.datasets["covariance/sigma"].data / found.datasets["covariance/sigma"].data[0]
    k = int(np.searchsorted(time, t))
    assert np.all(ratio[k:] <= 0.1) and np.any(ratio[k - 1] > 0.1)


def test_sigma_figure_groups_states_and_shades_segments(bank_turns, tmp_path):
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection
    from matplotlib.patches import Polygon, Rectangle

    captured = {}
    real_savefig = plt.Figure.savefig

    def keep(fig, *args, **kwargs):
        captured["fig"] = fig
        return real_savefig(fig, *args, **kwargs)

    plt.Figure.savefig = keep
    try:
        observability.FIGURES["observability-sigma.png"](bank_turns, tmp_path / "s.png")
    finally:
        plt.Figure.savefig = real_savefig
    fig = captured["fig"]
    axes = [ax for ax in fig.axes if ax.lines]
    assert len(axes) >= 6
    for ax in axes:
        assert len(ax.lines) <= 8, ax.get_title()  # curves only: no segment lines
        colours = [(line.get_color(), line.get_linestyle()) for line in ax.lines]
        assert len(set(colours)) == len(colours), ax.get_title()
        bands = [p for p in ax.patches if isinstance(p, Rectangle | Polygon)]
        bands += [c for c in ax.collections if isinstance(c, PolyCollection)]
        assert 1 <= len(bands) <= 40  # the six turns, not 315 segment boundaries
    title = fig._suptitle.get_text()
    assert "full rank" in title
    # bg_z ends near its prior (0.98): the title must not call it observable without saying so
    poorly = title.split("poorly observable")[1]
    assert "bg_z" in poorly and "dr_N" not in poorly
    plt.close(fig)


def test_singular_value_figure_draws_the_smallest_eight(bank_turns, tmp_path):
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    captured = {}
    real_savefig = plt.Figure.savefig

    def keep(fig, *args, **kwargs):
        captured["fig"] = fig
        return real_savefig(fig, *args, **kwargs)

    plt.Figure.savefig = keep
    try:
        observability.FIGURES["observability-singular-values.png"](bank_turns, tmp_path / "v.png")
    finally:
        plt.Figure.savefig = real_savefig
    (ax,) = captured["fig"].axes
    labels = [line.get_label() for line in ax.lines]
    assert labels == [*(f"s{k}" for k in range(19, 27)), "rank tolerance"]  # 26 states
    plt.close(captured["fig"])
