"""The sweep file of ``inins sweep`` (spec §8): a command, a base scenario and its axes.

::

    command: calibrate-bias                # a command of inins.commands.COMMANDS
    base: ../calibrate-bias/default.yaml   # relative to this file; default: the shipped one
    set:                                   # constant overrides, as --set
      simulate.imu.gyro.arw_deg_rth: 0.001
    grid:                                  # every combination (the last key varies fastest)
      simulate.motion.1.duration_s: [300, 600]
      simulate.mount.rotations.0.angle_deg: {start: 0.0, stop: 0.01, num: 3}
    zip:                                   # keys of one group vary together
      - {simulate.site.lat_deg: [10, 37], simulate.site.lon_deg: [100, 127]}
    seeds: 100                             # 0..99; or a list; or {start: 1000, count: 100}
    aggregate: {results: [beta_x_dph], percentiles: [5, 50, 95]}

A key path is written as for ``--set`` (``motion.3.duration_s``). A point runs
exactly as ``inins CMD BASE --set KEY=VALUE ... --seed SEED`` would; without
``seeds`` each point uses the base scenario's seed.
"""

import math
from typing import Any

from pydantic import Field, field_validator, model_validator

from inins.scenario.base import ScenarioPath, ScenarioSection
from inins.scenario.validation import KeyPathError


class ValueRange(ScenarioSection):
    """Evenly spaced numbers from ``start`` to ``stop`` (both included): give
    ``step`` or ``num``."""

    start: float = Field(description="first value (unit of the swept key)")
    stop: float = Field(description="last value, included (unit of the swept key)")
    step: float | None = Field(None, description="spacing; the last value is <= stop (unit)")
    num: int | None = Field(None, ge=1, description="number of values, linspace (1)")

    @model_validator(mode="after")
    def _one_of(self):
        for key in ("start", "stop", "step"):
            value = getattr(self, key)
            if value is not None and not math.isfinite(value):
                raise KeyPathError((key,), f"must be a finite number, got {value}")
        if (self.step is None) == (self.num is None):
            raise KeyPathError(("step",), "give exactly one of step and num")
        if self.step is not None and (self.step == 0 or (self.stop - self.start) / self.step < 0):
            raise KeyPathError(("step",), "step must be nonzero and lead from start to stop")
        if self.step is not None and not math.isfinite((self.stop - self.start) / self.step):
            raise KeyPathError(("step",), "(stop - start) / step overflows: step too small")
        return self

    def count(self) -> int:
        """Number of values, without building them (a range may be too long to expand)."""
        if self.num is not None:
            return self.num
        return math.floor((self.stop - self.start) / self.step * (1 + 1e-12) + 1e-9) + 1

    def values(self) -> list[float]:
        """The values, as floats."""
        if self.num is not None:
            if self.num == 1:
                return [self.start]
            span = self.stop - self.start
            return [self.start + span * i / (self.num - 1) for i in range(self.num)]
        return [self.start + i * self.step for i in range(self.count())]


class SeedRange(ScenarioSection):
    """``count`` consecutive seeds from ``start``."""

    start: int = Field(0, ge=0, description="first seed (1)")
    count: int = Field(ge=1, description="number of seeds (1)")


class AggregateSettings(ScenarioSection):
    """Statistics written and printed after the sweep, per axis value and over all points."""

    results: list[str] | None = Field(
        None, description="result names to summarise; default: every numeric result"
    )
    percentiles: list[float] = Field(
        [5.0, 50.0, 95.0], description="percentiles to report, each in [0, 100] (%)"
    )

    @field_validator("percentiles")
    @classmethod
    def _in_range(cls, value):
        if any(not 0 <= p <= 100 for p in value):
            raise ValueError("percentiles must lie in [0, 100]")
        return value


class SweepScenario(ScenarioSection):
    """A sweep: one command, one base scenario, grid and zipped axes, Monte Carlo seeds."""

    command: str = Field(description="the command every point runs (calibrate-bias, ...)")
    base: ScenarioPath | None = Field(
        None,
        description="base scenario file (relative to the sweep file); default: the "
        "command's shipped default scenario",
    )
    set: dict[str, Any] = Field(
        default_factory=dict, description="overrides applied to every point, as --set KEY=VALUE"
    )
    grid: dict[str, list[Any] | ValueRange] = Field(
        default_factory=dict,
        description="key path -> list of values or a range; every combination is run",
    )
    zip: list[dict[str, list[Any]]] = Field(
        default_factory=list,
        description="groups of key paths whose value lists (of equal length) vary together",
    )
    seeds: int | list[int] | SeedRange | None = Field(
        None,
        description="Monte Carlo seeds: N (0..N-1), a list, or {start, count}; "
        "default: the base scenario's seed",
    )
    aggregate: AggregateSettings = Field(default_factory=AggregateSettings)

    @field_validator("seeds")
    @classmethod
    def _seeds(cls, value):
        if isinstance(value, int) and value < 1:
            raise ValueError("seeds: N needs N >= 1")
        if isinstance(value, list) and (not value or any(s < 0 for s in value)):
            raise ValueError("seeds: a list of integers >= 0, not empty")
        return value

    @field_validator("grid")
    @classmethod
    def _non_empty(cls, value):
        for key, values in value.items():
            if isinstance(values, list) and not values:
                raise KeyPathError((key,), "an axis needs at least one value")
        return value

    @model_validator(mode="after")
    def _zip_lengths(self):
        seen = set(self.grid) | set(self.set)
        for i, group in enumerate(self.zip):
            lengths = {len(v) for v in group.values()}
            if not group or len(lengths) != 1 or 0 in lengths:
                raise KeyPathError(("zip", i), "a zip group needs lists of one equal length >= 1")
            for key in group:
                if key in seen:
                    raise KeyPathError(("zip", i, key), "this key is set twice")
                seen.add(key)
        for key in self.grid:
            if key in self.set:
                raise KeyPathError(("grid", key), "this key is also in set:")
        return self

    def seed_list(self) -> list[int | None]:
        """The Monte Carlo seeds; ``[None]`` (the scenario's seed) without ``seeds``."""
        if self.seeds is None:
            return [None]
        if isinstance(self.seeds, int):
            return list(range(self.seeds))
        if isinstance(self.seeds, SeedRange):
            return list(range(self.seeds.start, self.seeds.start + self.seeds.count))
        return list(self.seeds)

    def point_count(self) -> int:
        """Number of points (grid product x zip length x seeds), without expanding any axis."""
        count = self.seed_count()
        for values in self.grid.values():
            count *= len(values) if isinstance(values, list) else values.count()
        for group in self.zip:
            count *= len(next(iter(group.values())))
        return count

    def seed_count(self) -> int:
        """Number of seeds, without building the list."""
        if self.seeds is None:
            return 1
        if isinstance(self.seeds, int):
            return self.seeds
        if isinstance(self.seeds, SeedRange):
            return self.seeds.count
        return len(self.seeds)
