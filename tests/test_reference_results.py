"""The shipped scenarios reproduce their stored results, to a tolerance in physical units.

``tests/data/reference_summaries.json`` holds the ``results`` and ``truth`` of every
shipped scenario's ``summary.json`` (default seed). A result agrees when it is within

    max(relative x |reference|, 1e-6 x the scale of its unit)

where the unit is the suffix of its name (:data:`SCALE`: the order of magnitude such
a quantity has in these scenarios, e.g. 1 deg/h for a gyro bias, 1 m for a position
error): a closed-form or table result must agree to nine digits, and near zero to a
millionth of its quantity's scale. The estimates of a filter or an iterated fit
(:data:`ESTIMATORS`) amplify a rounding difference of another processor, BLAS or
numpy, and agree to seven digits: the recorded PSINS drive's z-gyro bias moves by
7e-9 of itself between two x86-64 processors, and the lc-drive's y-accelerometer bias
and the table-free MEMS scale factors by up to 1e-8 with kernels compiled for a generic
x86-64 CPU, numpy's AVX2 loops off and OpenBLAS's Nehalem kernels (``.ci/run`` runs
these tests so too). An estimate the data determine poorly sits at the bottom of a flat
cost whose minimiser moves with the rounding by more than that (the table-free MEMS
fit's first heading, 8.8 deg 1-sigma, by 4e-4 deg under the generic target): an
estimate with a 1-sigma among the results (``X_sigma_<unit>`` beside ``X_<unit>``,
``X_u_<unit>``), and that 1-sigma itself, agree also within :data:`OF_SIGMA` of the
1-sigma, four orders of magnitude below what the data tell apart. A change of physics
moves the results by far more. Counts, ranks
and flags agree exactly. Bit-identity is asked only between two code paths in one
process (e.g. ``tests/ekf/test_fused_epoch.py``).

A deliberate change of arithmetic updates the reference in the same commit and says
why: ``python -m tests.test_reference_results CONFIG...`` rewrites the entries of the
named scenarios from a run of the current tree (and adds new ones).
"""

import json
import math
import re
from pathlib import Path

import pytest

from inins.commands import find_command
from inins.commands.execute import execute

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = json.loads((ROOT / "tests" / "data" / "reference_summaries.json").read_text())

VOLATILE = {"realtime_factor", "update_time_mean_s", "post_filter_wall_s", "post_smoother_wall_s"}
"""Results that measure the machine, not the arithmetic (only checked to be present)."""

RELATIVE = 1e-9
"""Agreement asked of a closed-form or table result, relative to its reference value."""
ESTIMATORS = {"run-ekf": 1e-7, "calibrate-imu": 1e-7, "noise": 1e-7, "import-flight": 1e-7}
"""Relative agreement asked of the commands whose results a filter or an iterated
least-squares fit gives."""
OF_SIGMA = 1e-4
"""Agreement asked of an estimator's estimate with a 1-sigma, as a fraction of it."""
OF_SCALE = 1e-6
"""Agreement asked of every result, as a fraction of its unit's :data:`SCALE`."""
SCALE = {
    "dph": 1.0,  # deg/h: gyro biases and their sigma, 0.001-20 deg/h
    "deg": 0.1,  # deg: attitude and heading errors; headings themselves are within 1e-9
    "arcsec": 10.0,  # misalignments, mount rotations, azimuth offsets
    "m": 1.0,  # position errors, drifts, residuals; track lengths are within 1e-9
    "mps": 0.1,  # velocity errors
    "ug": 10.0,  # accelerometer biases
    "mg": 1.0,
    "ppm": 10.0,  # scale factors
    "deg_rth": 1e-3,  # angle random walk
    "ug_rthz": 10.0,  # velocity random walk
    "s": 1e-3,  # durations and time offsets
    "hz": 1.0,
    "pct": 1.0,
    "mps2": 0.01,  # specific-force residuals
    "m2ps4": 1e-3,
    "ug_s": 10.0,  # quantization
    "dph_rth": 1.0,  # rate random walk
    "ug_rth": 10.0,
    "dph_per_h": 1.0,  # rate ramp
    "ug_per_h": 10.0,
}
"""Order of magnitude of a quantity of each unit (name suffix) in these scenarios."""
DIMENSIONLESS_SCALE = 1e-3
"""Scale of a float without a unit suffix (NEES, NIS, sigma ratios, DOP)."""


def scale(name: str) -> float:
    """The :data:`SCALE` of result ``name``'s unit (its longest matching suffix, after
    an interval's ``_lo``/``_hi``)."""
    base = re.sub(r"_(lo|hi)$", "", name)
    for unit in sorted(SCALE, key=len, reverse=True):
        if re.search(rf"_{unit}$", base):
            return SCALE[unit]
    return DIMENSIONLESS_SCALE


def sigma_of(name: str, results: dict):
    """The reference 1-sigma of estimate ``name`` (or of the estimate whose 1-sigma or
    expanded uncertainty ``name`` is) among ``results``, None if it has none."""
    for unit in sorted(SCALE, key=len, reverse=True):  # units with an underscore
        if name.endswith("_" + unit):
            base = re.sub(r"_(sigma|u|est|lo|hi)$", "", name[: -len(unit) - 1])
            value = results.get(f"{base}_sigma_{unit}")
            return value if isinstance(value, float) and math.isfinite(value) else None
    return None


def agrees(name: str, got, want, relative: float = RELATIVE, sigma=None) -> bool:
    """Whether result ``name`` reproduces its reference value (module docstring);
    ``sigma``: its reference 1-sigma where an estimator gives one."""
    if want is None or got is None or isinstance(want, bool) or isinstance(got, bool):
        return got is want or (got == want and type(got) is type(want))
    if isinstance(want, int) and isinstance(got, int):
        return got == want
    if math.isnan(want) or math.isnan(got):
        return math.isnan(want) and math.isnan(got)
    tolerance = max(relative * abs(want), OF_SCALE * scale(name))
    return abs(got - want) <= max(tolerance, OF_SIGMA * (sigma or 0.0))


def test_agreement_is_tight_for_tables_and_in_physical_units_for_filters():
    assert agrees("azimuth_offset_arcsec", 74.26321676838042, 74.26321676838043)
    assert not agrees("azimuth_offset_arcsec", 74.2632, 74.2633)  # 0.1 mas
    filtered = ESTIMATORS["run-ekf"]
    assert agrees("gyro_bias_z_est_dph", 20.362785017870852, 20.362784849986927, filtered)
    assert not agrees("gyro_bias_z_est_dph", 20.3628, 20.3627, filtered)  # 1e-4 deg/h
    assert agrees("post_accel_bias_y_ug", 3160.365419891142, 3160.3653865193087, filtered)
    assert not agrees("post_accel_bias_y_ug", 3160.366, 3160.365, filtered)  # 1 ng
    assert agrees("tilt_y_arcsec", -2.5586846799065617e-11, -3.703684365233427e-11)
    assert not agrees("pos_err_rms_m", 1.000002, 1.0)  # 2 micrometres
    assert agrees("nis_mean", 1.0132196686582724, 1.0132196687494222, filtered)
    assert not agrees("nis_mean", 1.01322, 1.01321, filtered)
    assert not agrees("sigma_ratio_phi_N", 0.000626, 0.000625)
    assert not agrees("rank", 11, 12) and not agrees("observable_ba_x", False, True)
    assert agrees("practically_observable_after_s", None, None)
    assert scale("gyro_x_rrw_dph_rth_hi") == SCALE["dph_rth"] and scale("heading_deg") == 0.1
    assert not agrees("pos_err_rms_m", None, 1.0)
    # a poorly determined estimate: within 1e-4 of its own 1-sigma, not beyond
    results = {"table_free_heading_sigma_deg": 8.802, "table_free_mg_zy_sigma_arcsec": 39.03}
    sigma = sigma_of("table_free_heading_deg", results)
    assert sigma == 8.802 and sigma_of("table_free_heading_sigma_deg", results) == 8.802
    assert sigma_of("table_free_mg_zy_u_arcsec", results) == 39.03
    assert sigma_of("table_free_sg_y_ppm", results) is None
    assert agrees("table_free_heading_deg", 3.30670, 3.30708, filtered, sigma)
    assert not agrees("table_free_heading_deg", 3.3067, 3.3077, filtered, sigma)  # 1e-3 deg
    assert not agrees("table_free_heading_deg", 3.30670, 3.30708, filtered)


@pytest.mark.parametrize("config", sorted(REFERENCE))
def test_shipped_scenario_reproduces_the_reference(config):
    ref = REFERENCE[config]
    summary = execute(find_command(ref["command"]), ROOT / config).summary
    assert summary["seed"] == ref["seed"]
    relative = ESTIMATORS.get(ref["command"], RELATIVE)
    estimator = ref["command"] in ESTIMATORS
    for part in ("results", "truth"):
        got, want = summary[part], ref[part]
        assert sorted(got) == sorted(want), part
        diff = {
            k: (got[k], want[k])
            for k in want
            if k not in VOLATILE
            and not agrees(k, got[k], want[k], relative, sigma_of(k, want) if estimator else None)
        }
        assert diff == {}, f"{part} differ: {diff}"


PAPER_FOLDERS = {"paper000": "calibrate-bias", "paper003": "run-ekf"}
"""The command of the scenarios in a folder named after a paper."""


def _update(configs):
    """Rewrite the reference entries of ``configs`` (paths relative to the repository)."""
    data = dict(REFERENCE)
    for config in configs:  # configs/<command>/<name>.yaml unless already listed
        folder = Path(config).parent.name
        command = data.get(config, {}).get("command") or PAPER_FOLDERS.get(folder, folder)
        summary = execute(find_command(command), ROOT / config).summary
        data[config] = {
            "command": command,
            "results": summary["results"],
            "seed": summary["seed"],
            "truth": summary["truth"],
        }
    path = ROOT / "tests" / "data" / "reference_summaries.json"
    path.write_text(json.dumps(dict(sorted(data.items())), indent=1))  # the file's own format


if __name__ == "__main__":
    import sys

    _update(sys.argv[1:])
