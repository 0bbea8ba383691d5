"""Neutral result containers and text tables shared by the commands and the I/O layer.

Methods (``inins.table``, ``inins.calibration``) return a :class:`CommandResult`
of plain numpy arrays; :mod:`inins.io` writes it to HDF5, a text report and
``summary.json``. Methods that produce more data than fits in memory stream it
into a :class:`SeriesSink` handed to them by the caller. Nothing here imports
h5py, yaml or the CLI.
"""

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np


@dataclass(frozen=True)
class Series:
    """One dataset: an array with its unit and frame.

    Attributes
    ----------
    data : ndarray
        Leading axis is time (or the item index).
    units : str
        SI unit string (``"rad"``, ``"m/s"``, ``"s"``, ``"1"`` for dimensionless).
    frame : str
        Frame of vector or matrix data (``"n"``, ``"b"``, ``"t"``, ``"nb"`` for
        ``mat_nb``/``quat_nb``); ``""`` for scalars.
    description : str
        One line saying what the dataset is.
    """

    data: np.ndarray
    units: str
    frame: str = ""
    description: str = ""


@dataclass(frozen=True)
class CommandResult:
    """Everything one command produced.

    Attributes
    ----------
    command : str
        ``"simulate-table"``, ``"calibrate-bias"``, ...
    results : dict
        Flat name -> number (or None where a method is not applicable); names
        carry their lab unit as a suffix (``beta_x_dph``).
    truth : dict
        The same names, where truth is known (simulation).
    datasets : dict
        HDF5 path (``"group/name"``) -> :class:`Series`.
    attrs : dict
        HDF5 group path (``""`` for the root) -> attributes (SI, unit in the name).
    report : str
        Body of the text report (the I/O layer adds the header and checks).
    warnings : tuple of str
        Things the user should know (a method not applicable, a fallback taken).
    """

    command: str
    results: dict
    truth: dict = field(default_factory=dict)
    datasets: dict = field(default_factory=dict)
    attrs: dict = field(default_factory=dict)
    report: str = ""
    warnings: tuple = ()


class SeriesSink(Protocol):
    """Where a method streams long series, chunk by chunk.

    ``create`` declares a dataset once; ``append`` adds rows along the leading
    axis; ``set_attrs`` attaches attributes to a group or dataset path.
    """

    def create(
        self,
        path: str,
        row_shape: tuple,
        dtype,
        units: str,
        frame: str = "",
        description: str = "",
        expected_rows: int | None = None,
        attrs: dict | None = None,
    ) -> None: ...

    def append(self, path: str, rows: np.ndarray) -> None: ...

    def set_attrs(self, path: str, attrs: dict) -> None: ...


class NullSink:
    """A :class:`SeriesSink` that keeps nothing (a run whose series nobody reads)."""

    def create(self, path, *args, **kwargs):
        """Declare nothing."""

    def append(self, path, rows):
        """Keep nothing."""

    def set_attrs(self, path, attrs):
        """Keep nothing."""


class MemorySink:
    """A :class:`SeriesSink` that keeps everything in memory (tests, short runs)."""

    def __init__(self):
        self.meta = {}
        self.attrs = {}
        self._rows = {}

    def create(
        self,
        path,
        row_shape,
        dtype,
        units,
        frame="",
        description="",
        expected_rows=None,
        attrs=None,
    ):
        self.meta[path] = (tuple(row_shape), np.dtype(dtype), units, frame, description)
        self._rows[path] = []
        if attrs:
            self.attrs.setdefault(path, {}).update(attrs)

    def append(self, path, rows):
        row_shape, dtype = self.meta[path][:2]
        rows = np.asarray(rows, dtype=dtype)
        if rows.shape[1:] != row_shape:
            raise ValueError(f"{path}: rows of shape {rows.shape[1:]}, declared {row_shape}")
        self._rows[path].append(rows)

    def set_attrs(self, path, attrs):
        self.attrs.setdefault(path, {}).update(attrs)

    def __getitem__(self, path):
        row_shape, dtype = self.meta[path][:2]
        parts = self._rows[path]
        return np.concatenate(parts) if parts else np.empty((0, *row_shape), dtype)


# --------------------------------------------------------------------------- text tables


def format_value(value, fmt: str = ".6g") -> str:
    """One cell: numbers with ``fmt``, None as ``n/a``, booleans as yes/no."""
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if hasattr(value, "item") and getattr(value, "ndim", 0) == 0:
        value = value.item()
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return "nan" if math.isnan(value) else format(value, fmt)
    return str(value)


def format_table(rows, headers, units=None, fmt: str = ".6g", indent: int = 0) -> str:
    """Rows as an aligned plain-text table.

    Parameters
    ----------
    rows : sequence of sequence
        Cells: numbers (right-aligned, formatted with ``fmt``), text
        (left-aligned), None (``n/a``).
    headers : sequence of str
        Column titles.
    units : sequence of str, optional
        Unit per column, shown under the title as ``[unit]`` (empty: none).
    fmt : str
        Number format, e.g. ``".6g"`` or ``".3e"``.
    indent : int
        Spaces before every line.

    Returns
    -------
    str
        Lines joined with newlines (no trailing newline).
    """
    rows = [list(r) for r in rows]
    ncol = len(headers)
    if any(len(r) != ncol for r in rows):
        raise ValueError(f"every row needs {ncol} cells")
    numeric = [
        bool(rows) and all(_is_number(r[c]) or r[c] is None for r in rows) for c in range(ncol)
    ]
    head = [list(headers)]
    if units is not None and any(units):
        head.append([f"[{u}]" if u else "" for u in units])
    body = [[format_value(v, fmt) for v in r] for r in rows]
    widths = [max(len(line[c]) for line in head + body) for c in range(ncol)]
    pad = " " * indent

    def line(cells):
        parts = [
            cell.rjust(widths[c]) if numeric[c] else cell.ljust(widths[c])
            for c, cell in enumerate(cells)
        ]
        return (pad + "  ".join(parts)).rstrip()

    rule = pad + "  ".join("-" * w for w in widths)
    return "\n".join([*(line(h) for h in head), rule, *(line(b) for b in body)])


def _is_number(value) -> bool:
    if hasattr(value, "item") and getattr(value, "ndim", 0) == 0:
        value = value.item()
    return isinstance(value, int | float) and not isinstance(value, bool)
