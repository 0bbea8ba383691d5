"""A tiny command used to test the whole CLI contract (registered by conftest)."""

from typing import Literal

import numpy as np
from pydantic import Field

from inins.core.units import DPH
from inins.results import CommandResult, Series, format_table
from inins.scenario.base import ScenarioModel
from inins.scenario.types import PositiveFloat, Vec3


class FakeScenario(ScenarioModel):
    """A fake gyro run."""

    name: str = Field(description="Name of the run")
    duration_s: PositiveFloat = Field(2.0, description="Length of the run [s]")
    rate_hz: PositiveFloat = Field(100.0, description="Sample rate [Hz]")
    bias_dph: Vec3 = Field((0.0, 0.0, 0.0), description="Gyro bias per axis [deg/h]")
    fail: Literal["no", "run", "late", "interrupt", "input"] = Field(
        "no", description="Where to fail (for tests)"
    )


def _fail(model, where):
    from inins.exceptions import InputError

    if model.fail == where == "input":
        raise InputError("the data make no sense", source="log.csv", key="column gyro_x")
    if model.fail == where == "interrupt":
        raise KeyboardInterrupt
    if model.fail == where:
        raise RuntimeError(f"boom ({where})")


def run(model: FakeScenario, seed: int, *, sink=None, progress=None) -> CommandResult:
    """Return a result with two series, numbers, None and NaN."""
    for where in ("run", "input", "interrupt"):
        _fail(model, where)
    n = round(model.duration_s * model.rate_hz)
    rng = np.random.default_rng(seed)
    gyro = np.asarray(model.bias_dph) * DPH + rng.normal(0.0, 1e-9, (n, 3))
    estimate = gyro.mean(axis=0) / DPH
    report = format_table(
        [
            (axis, est, true)
            for axis, est, true in zip("xyz", estimate, model.bias_dph, strict=True)
        ],
        headers=("axis", "estimate", "truth"),
        units=("", "deg/h", "deg/h"),
    )
    return CommandResult(
        command="fake",
        results={
            "bias_x_dph": estimate[0],
            "bias_y_dph": np.float32(estimate[1]),
            "n_samples": np.int64(n),
            "beta_z_dph": None,
            "nan_dph": float("nan"),
            "seed_used": seed,
        },
        truth={"bias_x_dph": model.bias_dph[0], "bias_y_dph": model.bias_dph[1]},
        datasets={
            "imu/time": Series(np.arange(n) / model.rate_hz, "s", "", "sample time"),
            "imu/gyro": Series(gyro, "rad/s", "b", "angular rate"),
            "steps/label": Series(np.array(["hold", "turn"]), "1", "", "step names"),
        },
        attrs={
            "imu": {"rate_hz": model.rate_hz, "errors": {"bias_rad_s": gyro[0]}},
            "": {"name": model.name},
        },
        report=f"Gyro bias\n\n{report}",
        warnings=("fake warning",),
    )


def run_streaming(model: FakeScenario, seed: int, *, sink=None, progress=None) -> CommandResult:
    """Stream a long series into the sink, then return a small result."""
    n = round(model.duration_s * model.rate_hz)
    sink.create("imu/long", (3,), np.float64, "rad/s", "b", "streamed rate", expected_rows=n)
    rng = np.random.default_rng(seed)
    block = 10_000
    for k0 in range(0, n, block):
        if model.fail == "late" and k0 >= n // 2:
            raise RuntimeError("boom (late)")
        sink.append("imu/long", rng.normal(size=(min(block, n - k0), 3)))
    sink.set_attrs("imu/long", {"dt_s": 1.0 / model.rate_hz})
    return CommandResult(
        command="fake",
        results={"n_samples": n},
        datasets={"imu/rate": Series(np.array([model.rate_hz]), "Hz")},
    )


SCENARIO_MODEL = FakeScenario
