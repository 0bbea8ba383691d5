"""The points of a sweep: axes expanded into ``--set`` overrides and seeds, checked
before anything runs.

A point is the command line ``inins CMD BASE --set K=V ... --seed S``: its
overrides are ``key=<JSON of the value>`` strings (JSON is YAML, and a float's
shortest repr reads back to the same double), so the scenario a point validates is
the one the single command would build.
"""

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from inins.exceptions import InputError

DEFAULT_MAX_POINTS = 100_000
_VALIDATE_ALL_UP_TO = 200  # distinct values of an axis checked one by one

if TYPE_CHECKING:
    from inins.scenario.sweep import AggregateSettings


@dataclass(frozen=True)
class Axis:
    """One swept dimension: a grid key, or a zip group of keys varied together.

    Attributes
    ----------
    keys : tuple of str
        Key paths (one for a grid axis).
    values : tuple of tuple
        One tuple of values (one per key) per step of the axis.
    where : str
        Key path of the axis in the sweep file, for messages.
    """

    keys: tuple
    values: tuple
    where: str


@dataclass(frozen=True)
class Point:
    """One run of the sweep.

    Attributes
    ----------
    index : int
        Position in the sweep: grid keys in file order, then the zip groups, the
        last fastest; seeds innermost.
    axis_values : tuple
        One value per swept key (:attr:`SweepPlan.axis_keys` order).
    overrides : tuple of str
        ``key=value`` items: the sweep's ``set:`` then the axes.
    seed : int or None
        None: the base scenario's seed.
    """

    index: int
    axis_values: tuple
    overrides: tuple
    seed: int | None

    @property
    def key(self) -> str:
        """Identity of the point across reruns (its overrides and seed)."""
        return json.dumps([list(self.overrides), self.seed])


@dataclass(frozen=True)
class SweepPlan:
    """Everything needed to run a sweep.

    Attributes
    ----------
    command : str
    base : Path or None
        Base scenario (None: the command's shipped default).
    base_text : str
        Its text, for the fingerprint.
    fixed : tuple of str
        Overrides from ``set:``.
    axes : tuple of Axis
    seeds : tuple
    aggregate : AggregateSettings
    source : str
        The sweep file, for messages.
    """

    command: str
    base: Path | None
    base_text: str
    fixed: tuple
    axes: tuple
    seeds: tuple
    aggregate: "AggregateSettings"
    source: str

    @property
    def axis_keys(self) -> tuple:
        """Every swept key path, in column order."""
        return tuple(k for axis in self.axes for k in axis.keys)

    @property
    def size(self) -> int:
        """Number of points."""
        return math.prod(len(a.values) for a in self.axes) * len(self.seeds)

    def points(self):
        """Yield the points in order."""
        import itertools

        steps = itertools.product(*(axis.values for axis in self.axes))
        index = 0
        for combo in steps:
            values = tuple(v for step in combo for v in step)
            overrides = self.fixed + tuple(
                override(k, v) for k, v in zip(self.axis_keys, values, strict=True)
            )
            for seed in self.seeds:
                yield Point(index, values, overrides, seed)
                index += 1

    def fingerprint(self) -> str:
        """Hash of what every point shares: command, base scenario text, ``set:``."""
        import hashlib

        blob = json.dumps([self.command, self.base_text, list(self.fixed)])
        return hashlib.sha256(blob.encode()).hexdigest()[:16]


def override(key: str, value) -> str:
    """The ``--set`` item of one key and value."""
    return f"{key}={json.dumps(value, allow_nan=False)}"


def load_sweep(path, max_points: int = DEFAULT_MAX_POINTS, overrides=(), seed=None) -> SweepPlan:
    """Read and check a sweep file; nothing runs.

    Checks, each an :class:`InputError` naming the sweep file and key: the file
    and its model (:class:`inins.scenario.sweep.SweepScenario`), the base
    scenario, the number of points (<= ``max_points``), and every axis value
    against the command's scenario model (an unknown key, a wrong type, a value
    out of range). ``overrides`` (``--set``) are applied to every point after the
    file's ``set:``; ``seed`` (``--seed``) is the seed of every point of a sweep without
    ``seeds:``.
    """
    from dataclasses import replace

    from pydantic import ValidationError

    from inins.scenario.base import _read_text
    from inins.scenario.sweep import SweepScenario
    from inins.scenario.validation import to_input_error
    from inins.scenario.yaml_source import parse_yaml

    source = str(path)
    data, lines = parse_yaml(_read_text(path, source), source)
    try:
        model = SweepScenario.model_validate(
            data, context={"base_dir": Path(path).resolve().parent}
        )
    except ValidationError as exc:
        raise to_input_error(
            exc, data=data, lines=lines, source=source, model_cls=SweepScenario, overrides={}
        ) from None
    count = model.point_count()  # before any axis is expanded in memory
    if count > max_points:
        raise InputError(
            f"the sweep has {count:,} points, more than --max-points {max_points:,}",
            source=source,
        )
    plan = _plan(model, source)
    for item in overrides:
        _check_key(item, "--set")
    plan = replace(plan, fixed=plan.fixed + tuple(overrides))
    if seed is not None:
        from inins.commands.execute import check_seed

        check_seed(seed)
        if model.seeds is not None:
            raise InputError(
                "the sweep file lists Monte Carlo seeds (seeds:); --seed would replace them",
                source=source,
                key="--seed",
            )
        plan = replace(plan, seeds=(int(seed),))
    validate_axes(plan)
    return plan


def _plan(model, source) -> SweepPlan:
    from inins.commands import find_command
    from inins.io.resources import config_path
    from inins.scenario.base import _read_text

    try:
        spec = find_command(model.command)
    except InputError as exc:
        raise InputError(exc.message, source=source, key="command") from None
    if not spec.available:
        raise InputError(
            f"inins {spec.name} is not yet available in this version", source=source, key="command"
        )
    base_file = model.base or config_path(spec.name, spec.default)
    base_text = _read_text(base_file, str(base_file))
    axes = []
    for key, values in model.grid.items():
        listed = values if isinstance(values, list) else values.values()
        axes.append(Axis((key,), tuple((v,) for v in listed), f"grid.{key}"))
    for i, group in enumerate(model.zip):
        keys = tuple(group)
        axes.append(Axis(keys, tuple(zip(*group.values(), strict=True)), f"zip[{i}]"))
    fixed = tuple(override(k, v) for k, v in model.set.items())
    for item in (*fixed, *(override(k, axis.values[0][0]) for axis in axes for k in axis.keys)):
        _check_key(item, source)
    return SweepPlan(
        model.command,
        model.base,
        base_text,
        fixed,
        tuple(axes),
        tuple(model.seed_list()),
        model.aggregate,
        source,
    )


def _check_key(item: str, source: str) -> None:
    from inins.scenario.yaml_source import parse_override

    try:
        parse_override(item)
    except InputError as exc:
        raise InputError(exc.message, source=source) from None


def validate_axes(plan: SweepPlan) -> None:
    """Load the scenario of every axis value (others at their first value); raise the
    first problem as an :class:`InputError` naming the axis."""
    from inins.commands import find_command

    spec = find_command(plan.command)
    first = [axis.values[0] for axis in plan.axes]
    for n, axis in enumerate(plan.axes):
        for step in _representatives(axis.values):
            chosen = [*first[:n], step, *first[n + 1 :]]
            overrides = plan.fixed + tuple(
                override(k, v)
                for a, s in zip(plan.axes, chosen, strict=True)
                for k, v in zip(a.keys, s, strict=True)
            )
            try:
                _check_point(spec, plan.base, overrides)
            except InputError as exc:
                raise InputError(
                    f"{exc} (value {json.dumps(list(step))[1:-1]})",
                    source=plan.source,
                    key=axis.where,
                ) from None
    if not plan.axes:
        try:
            _check_point(spec, plan.base, plan.fixed)
        except InputError as exc:
            raise InputError(str(exc), source=plan.source, key="set") from None


def _check_point(spec, base, overrides) -> None:
    """Load a point's scenario and refuse it as the single command would before its run:
    its size against the stated limits and its numerical edges
    (:func:`inins.commands.budget.check_budget`, without an output folder)."""
    from inins.commands.budget import check_budget
    from inins.commands.execute import load

    module, loaded = load(spec, base, overrides)
    estimate = getattr(module, "estimate", None)
    if estimate is None:
        return
    try:
        check_budget(estimate(loaded.model), None)
    except InputError as exc:
        hint = "; pass --force to run anyway"
        if exc.message.endswith(hint):  # a sweep has no --force: run that point alone
            exc.message = exc.message[: -len(hint)] + (
                "; a sweep runs no point beyond the limits (run it alone with --force)"
            )
            exc.args = (exc.message,)
        raise


def _representatives(values) -> list:
    """The axis values to validate: all if few; else every non-numeric one (distinct)
    and the smallest and largest number of each position."""
    distinct = list({json.dumps(v): v for v in values}.values())
    if len(distinct) <= _VALIDATE_ALL_UP_TO:
        return distinct
    chosen = {}
    for pos in range(len(values[0])):
        numbers = [v for v in distinct if _is_number(v[pos])]
        if not numbers:
            continue
        for pick in (min(numbers, key=lambda v: v[pos]), max(numbers, key=lambda v: v[pos])):
            chosen[json.dumps(pick)] = pick
    others = [v for v in distinct if not all(_is_number(x) for x in v)]
    for v in others[:_VALIDATE_ALL_UP_TO]:
        chosen[json.dumps(v)] = v
    return list(chosen.values())


def _is_number(value) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)
