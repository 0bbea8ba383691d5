"""The one-call analysis and the package's import rule."""

import ast
from pathlib import Path

import numpy as np
import pytest

from inins.core import earth
from inins.core.units import DEG, DPH, MG
from inins.exceptions import InputError
from inins.observability import analysis, models
from inins.observability import measurements as meas
from inins.observability.segments import make_segment

PACKAGE = Path(__file__).resolve().parents[2] / "inins" / "observability"
ALLOWED = (
    "numpy",
    "scipy",
    "numba",
    "inins.core",
    "inins.gnss",
    "inins.exceptions",
    "inins.observability",
    "dataclasses",
    "enum",
)


def test_observability_imports_only_the_numeric_core():
    for path in sorted(PACKAGE.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            for name in names:
                assert any(name == a or name.startswith(a + ".") for a in ALLOWED), (path, name)


def test_report_joins_rank_gramian_and_covariance_per_state():
    lla = (37 * DEG, 127 * DEG, 0.0)
    segs = [make_segment(300.0, lla, heading=0.0), make_segment(300.0, lla, heading=90 * DEG)]
    sigma_0 = np.r_[[0.1] * 3, [1 * DEG] * 3, [1 * MG] * 3, [0.1 * DPH] * 3]
    vel = [meas.Measurement("velocity", 0.01)]
    one = analysis.analyse(models.MODELS["align12"], segs[:1], vel, sigma_0=sigma_0)
    assert (one.rank, one.n_states, one.n_unobservable, one.gramian_rank) == (9, 12, 3, 9)
    assert one.model == "align12" and len(one.combinations) == 3
    assert [s.name for s in one.states] == list(models.ALIGN12.names)
    # heading and east gyro bias sit on their floor (test_obs_covariance): with
    # k = W cos L sigma_phi / sigma_bg (gyrocompass error bg_E / (W cos L) against
    # the prior), phi_D falls to 1 / sqrt(1 + k^2) and bg_y to k / sqrt(1 + k^2)
    k = earth.RATE * np.cos(37 * DEG) * sigma_0[5] / sigma_0[10]
    assert not one.state("phi_D").observable and not one.state("bg_y").observable
    assert one.state("phi_D").sigma_ratio == pytest.approx(1 / np.hypot(1, k), rel=0.01)
    assert one.state("bg_y").sigma_ratio == pytest.approx(k / np.hypot(1, k), rel=0.01)
    assert one.state("ba_z").observable and one.state("ba_z").sigma_ratio < 0.01  # 0.001
    assert one.state("bg_y").unit == "rad/s"
    both = analysis.analyse(models.MODELS["align12"], segs, vel, sigma_0=sigma_0)
    assert both.rank == 12 == both.gramian_rank and all(s.observable for s in both.states)
    # after the heading change the heading error is estimated (measured 0.017)
    assert both.state("phi_D").sigma_ratio < 0.05
    bare = analysis.analyse(models.MODELS["align12"], segs, vel)
    assert bare.covariance is None and np.isnan(bare.state("phi_D").sigma_ratio)
    with pytest.raises(KeyError):
        bare.state("psi_D")


def test_warnings_and_bad_names():
    lla = (37 * DEG, 127 * DEG, 0.0)
    seg = make_segment(60.0, lla, heading=0.0)
    los = np.array([[0.0, 0.0, -1.0], [0.6, 0.0, -0.8], [0.0, 0.6, -0.8]])
    dd = meas.Measurement("dd_phase", 0.005, baseline_b=(0, 1.5, 0), los_n=los)
    found = analysis.analyse(models.MODELS["align12"], [seg], [dd])
    assert found.pwcs.method == "total" and "total observability matrix" in found.warnings[0]
    assert (
        analysis.analyse(
            models.MODELS["align12"], [seg], [meas.Measurement("velocity", 0.1)]
        ).warnings
        == ()
    )
    with pytest.raises(InputError, match="unknown model") as err:
        models.model_by_name("ekf18", key="model.name")
    assert err.value.key == "model.name"
    with pytest.raises(InputError, match="unknown state names") as err:
        models.custom_model(["dv_N", "psi_D"], key="model.states")
    assert err.value.key == "model.states"
    custom = models.custom_model(["dv_N", "dv_E", "phi_N", "phi_E", "phi_D"])
    assert len(custom.layout) == 5 and custom.transport_from_estimate
    with pytest.raises(InputError, match="segment"):
        analysis.analyse(custom, [], [meas.Measurement("velocity", 0.1)])
