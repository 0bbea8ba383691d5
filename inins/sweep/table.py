"""The flat table of a sweep: one row per finished point, built from the journal.

Columns, in order: ``id``, one per swept key path (its value; text as JSON when
not a number), ``seed``, ``status`` (passed, check-failed, error), ``passed``,
``error``, ``run_s`` (wall time of the point in its worker), ``cpu_s`` (its CPU
time), one per result (``beta_x_dph``; empty/NaN where not
applicable), ``truth.NAME`` per truth value, ``check[i]`` per scenario check
(the expression is in the HDF5 attributes and the CSV column title).
"""

import functools
import json
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SweepTable:
    """Rows of the finished points in sweep order.

    Attributes
    ----------
    ids : list of str
    axis_keys : tuple of str
    axis_values : list of tuple
    records : list of dict
        The worker records (:func:`inins.sweep.worker.run_point`).
    result_names, truth_names, check_names : list of str
        Union over the records, in first-seen order.
    group_keys : tuple of str
        The first key of each axis (a zip group is grouped by its first key).
    """

    ids: list
    axis_keys: tuple
    axis_values: list
    records: list
    result_names: list
    truth_names: list
    check_names: list
    group_keys: tuple = ()

    def result(self, name: str) -> np.ndarray:
        """Column of result ``name`` as float64 (NaN where missing), shape (n,)."""
        column = self._result_columns.get(name)
        if column is None:
            return np.full(len(self.records), np.nan)
        return column.copy()

    @functools.cached_property
    def _result_columns(self) -> dict:
        """Every result's column, filled in one pass over the records (the aggregates,
        the CSV and the HDF5 table each ask for every column)."""
        index = {name: j for j, name in enumerate(self.result_names)}
        out = np.full((len(index), len(self.records)), np.nan)
        for i, record in enumerate(self.records):
            for name, value in record["results"].items():
                if value is not None:
                    out[index[name], i] = value
        return {name: out[j] for name, j in index.items()}

    def axis(self, key: str) -> list:
        """Values of swept key ``key``, one per row."""
        i = self.axis_keys.index(key)
        return [v[i] for v in self.axis_values]

    def passed_checks(self) -> np.ndarray:
        """(n, k) bool: check j passed at row i (False where not evaluated)."""
        out = np.zeros((len(self.records), len(self.check_names)), dtype=bool)
        for i, r in enumerate(self.records):
            got = dict(r["checks"])
            for j, name in enumerate(self.check_names):
                out[i, j] = bool(got.get(name, False))
        return out


def _num(value) -> float:
    return np.nan if value is None else float(value)


def point_id(index: int, total: int) -> str:
    """Zero-padded id of point ``index`` (``p00042``), the ``runs/<id>`` folder name."""
    return f"p{index:0{max(5, len(str(total - 1)))}d}"


def build_table(plan, records_by_key: dict) -> SweepTable:
    """The table of the finished points of ``plan`` (a :class:`inins.sweep.plan.SweepPlan`)."""
    ids, values, records = [], [], []
    for point in plan.points():
        record = records_by_key.get(point.key)
        if record is None:
            continue
        ids.append(point_id(point.index, plan.size))
        values.append(point.axis_values)
        records.append(record)
    return SweepTable(
        ids,
        plan.axis_keys,
        values,
        records,
        _union(r["results"] for r in records),
        _union(r["truth"] for r in records),
        _union((name for name, _ in r["checks"]) for r in records),
        tuple(axis.keys[0] for axis in plan.axes),
    )


def _union(iterables) -> list:
    seen = {}
    for names in iterables:
        for name in names:
            seen.setdefault(name, None)
    return list(seen)


def _axis_column(values) -> list:
    if all(isinstance(v, int | float) and not isinstance(v, bool) for v in values):
        return [float(v) for v in values]
    return [v if isinstance(v, str) else json.dumps(v) for v in values]


def csv_columns(table: SweepTable) -> dict:
    """``{column title: values}`` for :func:`inins.io.sweep_files.write_table_csv`."""
    cols = {"id": table.ids}
    for key in table.axis_keys:
        cols[key] = _axis_column(table.axis(key))
    recs = table.records
    cols["seed"] = [r["seed"] for r in recs]
    cols["status"] = [r["status"] for r in recs]
    cols["passed"] = [r["status"] == "passed" for r in recs]
    cols["error"] = [r["error"] for r in recs]
    cols["run_s"] = [r["run_s"] for r in recs]
    cols["cpu_s"] = [r.get("cpu_s", float("nan")) for r in recs]
    for name in table.result_names:
        cols[name] = [r["results"].get(name) for r in recs]
    for name in table.truth_names:
        cols[f"truth.{name}"] = [r["truth"].get(name) for r in recs]
    passed = table.passed_checks()
    for j, name in enumerate(table.check_names):
        cols[f"check[{j}]: {name}"] = list(passed[:, j])
    return cols


def h5_groups(table: SweepTable, plan) -> tuple[dict, dict]:
    """``(groups, attrs)`` for :func:`inins.io.sweep_files.write_table_h5`.

    Layout: ``/points/{id, seed, status, passed, error, run_s, cpu_s}``,
    ``/axes/<key path>``, ``/results/<name>``, ``/truth/<name>``, ``/checks/passed``
    (n, k) with attribute ``expressions``; root attributes ``command``, ``base``,
    ``fingerprint``.
    """
    recs = table.records
    seeds = np.array([r["seed"] if r["seed"] is not None else -1 for r in recs], dtype=np.int64)
    groups = {
        "points": {
            "id": table.ids,
            "seed": seeds,
            "status": [r["status"] for r in recs],
            "passed": np.array([r["status"] == "passed" for r in recs], dtype=bool),
            "error": [r["error"] for r in recs],
            "run_s": np.array([r["run_s"] for r in recs], dtype=np.float64),
            "cpu_s": np.array([r.get("cpu_s", np.nan) for r in recs], dtype=np.float64),
        },
        "axes": {key: _axis_column(table.axis(key)) for key in table.axis_keys},
        "results": {name: table.result(name) for name in table.result_names},
        "truth": {
            name: np.array([_num(r["truth"].get(name)) for r in recs], dtype=np.float64)
            for name in table.truth_names
        },
        "checks": {"passed": table.passed_checks()},
    }
    attrs = {
        "": {
            "command": plan.command,
            "base": str(plan.base) if plan.base else f"(shipped default of {plan.command})",
            "fingerprint": plan.fingerprint(),
            "set": json.dumps(list(plan.fixed)),
            "points_planned": plan.size,
            "points_finished": len(recs),
        },
        "checks/passed": {"expressions": json.dumps(table.check_names)},
    }
    return groups, attrs
