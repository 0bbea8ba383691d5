"""``summary.json``: the flat, machine-readable outcome of one run (spec §1).

Shape::

    {"command": "calibrate-bias", "inins_version": "0.1.0",
     "scenario": "configs/calibrate-bias/default.yaml", "seed": 0,
     "results": {"beta_x_dph": 0.0016, "beta_y_dph": null},
     "truth": {"beta_x_dph": 0.0016},
     "checks": [{"name": "abs(err.beta_x_dph) < 0.002", "passed": true, "value": 1e-05}],
     "passed": true}

``scenario`` is the scenario's source name. Values are JSON numbers (numpy
scalars converted, integers kept), booleans, or null for None, NaN and
infinity. ``passed`` is true when every check passed (and when there are none).
"""

import json
import math

from inins.io.atomic import write_text_atomic


def json_scalar(value, name: str = "value"):
    """A result value as a JSON scalar.

    Parameters
    ----------
    value : bool, int, float, numpy scalar or None
    name : str
        For the error message.

    Returns
    -------
    bool, int, float or None
        None for None, NaN and infinities.

    Raises
    ------
    TypeError
        Anything else (arrays, text): results must be flat numbers.
    """
    if hasattr(value, "item") and getattr(value, "ndim", 0) == 0:
        value = value.item()
    if value is None or isinstance(value, bool | int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    raise TypeError(f"result {name!r} must be a number or None, got {type(value).__name__}")


def build_summary(command, inins_version, scenario, seed, results, truth, checks) -> dict:
    """The summary dict, ready for :func:`summary_text`.

    Parameters
    ----------
    command, inins_version, scenario : str
    seed : int
    results, truth : dict
        Flat name -> number or None.
    checks : list of dict
        From :func:`inins.scenario.checks.evaluate_checks`.
    """
    return {
        "command": command,
        "inins_version": inins_version,
        "scenario": scenario,
        "seed": int(seed),
        "results": {k: json_scalar(v, k) for k, v in results.items()},
        "truth": {k: json_scalar(v, k) for k, v in truth.items()},
        "checks": [
            {k: json_scalar(v) if k == "value" else v for k, v in c.items()} for c in checks
        ],
        "passed": all(c["passed"] for c in checks),
    }


def summary_text(summary: dict) -> str:
    """JSON text of a summary (strict JSON: no NaN)."""
    return json.dumps(summary, indent=2, allow_nan=False) + "\n"


def write_summary(path, summary: dict) -> None:
    """Write ``summary.json`` atomically."""
    write_text_atomic(path, summary_text(summary))
