"""The outcome of a run printed to a pipe without rich (:func:`plain_outcome`) is the
text rich prints there, character for character, on many summaries; where rich
would wrap, colour or measure text, rich prints it."""

import io
import math

import numpy as np
import pytest
from rich.console import Console

from inins.cli import _display

ALPHABET = list("abcdefghijklmnopqrstuvwxyz_0123456789 <=().[]")


def _name(rng, longest):
    return "".join(rng.choice(ALPHABET, size=int(rng.integers(1, longest + 1))))


def _value(rng):
    kind = rng.integers(7)
    if kind == 0:
        return int(rng.integers(-(10**9), 10**9))
    if kind == 1:
        return float(rng.choice([math.nan, math.inf, -math.inf, 0.0, -0.0]))
    if kind == 2:
        return None
    if kind == 3:
        return bool(rng.integers(2))
    if kind == 4:
        return _name(rng, 12)
    return float(rng.standard_normal() * 10.0 ** rng.integers(-12, 12))


def _summary(rng):
    longest = int(rng.choice([4, 8, 16, 45]))
    results = {_name(rng, longest): _value(rng) for _ in range(int(rng.integers(0, 30)))}
    for name in list(results)[: int(rng.integers(0, 5))]:  # some with a 1-sigma
        stem, _, unit = name.rpartition("_")
        if stem:
            results[f"{stem}_sigma_{unit}"] = _value(rng)
    truth = {n: _value(rng) for n in results if rng.random() < 0.3}
    checks = [
        {
            "name": _name(rng, longest),
            "value": _value(rng),
            "passed": bool(rng.integers(2)),
            **({"reason": _name(rng, 15)} if rng.random() < 0.3 else {}),
        }
        for _ in range(int(rng.integers(0, 6)))
    ]
    return {
        "command": "simulate-table",
        "scenario": "configs/simulate-table/default.yaml",
        "seed": int(rng.integers(0, 2**62)),
        "results": results,
        "truth": truth,
        "checks": checks,
        "passed": all(c["passed"] for c in checks),
    }


def _rich_text(summary, paths, elapsed, width):
    buffer = io.StringIO()
    out = Console(file=buffer, highlight=False, soft_wrap=True, width=width)
    _display.print_outcome_rich(summary, paths, elapsed, out)
    return buffer.getvalue()


@pytest.mark.parametrize("width", [40, 80, 132])
def test_plain_outcome_is_what_rich_prints_on_a_pipe(monkeypatch, width):
    monkeypatch.setenv("COLUMNS", str(width))
    for key in _display._TERMINAL_ENV:
        monkeypatch.delenv(key, raising=False)
    rng = np.random.default_rng(width)
    plain = 0
    for _ in range(150):
        summary = _summary(rng)
        paths = [f"out/{_name(rng, 10)}.h5", "out/summary.json"]
        elapsed = float(rng.uniform(0.0, 100.0))
        text = _display.plain_outcome(summary, paths, elapsed)
        if text is not None:
            plain += 1
            assert text == _rich_text(summary, paths, elapsed, width), summary
    # the plain path is taken where tables fit (a table wider than the console needs rich)
    assert plain >= {40: 1, 80: 25, 132: 50}[width]


def test_rich_prints_where_it_would_colour_or_measure(monkeypatch):
    monkeypatch.setenv("COLUMNS", "80")
    summary = {
        "command": "noise",
        "scenario": "s.yaml",
        "seed": 0,
        "results": {"x": 1.0},
        "truth": {},
        "checks": [],
        "passed": True,
    }
    assert _display.plain_outcome(summary, ["a.h5"], 1.0) is not None
    assert _display.plain_outcome(summary | {"results": {"\u00e9t\u00e9": 1.0}}, [], 1.0) is None
    assert _display.plain_outcome(summary, ["tab\there.h5"], 1.0) is None
    monkeypatch.setenv("FORCE_COLOR", "1")
    assert _display.plain_outcome(summary, ["a.h5"], 1.0) is None
