"""``--plot`` for every available command (issue 8, item 11): the PNG files exist,
are PNG, and the figure helpers compute what they say."""

from pathlib import Path

import numpy as np
import pytest

from inins.commands import find_command
from inins.commands.calibrate_bias_figures import _chosen_text
from inins.commands.execute import execute
from inins.commands.import_log_figures import allan_deviation

pytest.importorskip("matplotlib")
ROOT = Path(__file__).resolve().parents[2]
FAST = ["imu.sample_rate_hz=10", "output.truth_rate_hz=10"]


@pytest.mark.slow
@pytest.mark.parametrize(
    ("command", "items", "pngs"),
    [
        ("simulate-table", FAST, ["simulate-table.png"]),
        ("align-ett", [f"simulate.{i}" for i in FAST], ["align-ett.png"]),
        ("import-log", [], ["import-log.png"]),
        (
            "calibrate-bias",
            [f"simulate.{i}" for i in FAST],
            ["calibrate-bias-roll.png", "calibrate-bias-pitch.png"],
        ),
    ],
)
def test_plot_writes_the_figures(command, items, pngs, tmp_path):
    done = execute(find_command(command), None, items, outdir=tmp_path, figures=True)
    for name in pngs:
        assert tmp_path / name in done.paths
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not [p for p in tmp_path.iterdir() if ".partial-" in p.name]


def test_allan_deviation_of_white_noise():
    # white rate noise of sigma s at dt: sigma(tau) = s sqrt(dt / tau) (IEEE 952 C.1)
    rng = np.random.default_rng(1)
    dt, s = 0.01, 2.0
    tau, adev = allan_deviation(s * rng.standard_normal(400_000), dt)
    expected = s * np.sqrt(dt / tau)
    short = tau <= 10.0  # many clusters: within 10 %
    assert np.all(np.abs(adev[short] / expected[short] - 1) < 0.1)


def test_chosen_text_names_the_formula_or_none():
    from types import SimpleNamespace

    results = {
        "beta_x_dph": 0.01,
        "beta_x_sigma_dph": 0.001,
        "beta_x_eq44_dph": 0.01,
        "beta_y_dph": None,
    }
    assert _chosen_text(SimpleNamespace(results=results)) == (
        "chosen: beta_x = 0.01000 +/- 0.00100 deg/h (eq44); beta_y: no valid formula"
    )
