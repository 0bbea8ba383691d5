"""The table-data HDF5 layout, declared once: written by simulate-table and import-log,
read by calibrate-bias and align-ett (and by :class:`TableData` here).

:data:`LAYOUT` declares every dataset (name, dtype, row shape, units, frame,
description); :func:`declare` creates them in a :class:`inins.results.SeriesSink`,
:func:`append_chunk` writes a :class:`inins.core.records.TableChunk`,
:func:`encode_steps` / :func:`decode_steps` convert the step schedule.

Layout (every dataset carries ``units``, ``frame`` and ``description`` attributes)::

    /                     provenance attributes (inins.io.hdf5)
    /site                 attrs: lat_rad, lon_rad, height_m
    /imu                  attrs: t0_s (start of the first sample interval), dt_s,
                          sample_rate_hz. Sample k covers [t0 + k dt, t0 + (k+1) dt].
    /imu/dtheta  (n, 3)   gyro increments, b frame: float64 rad, or int32 pulse
                          counts (units "count") with attr pulse_weight (3,) in rad
    /imu/dv      (n, 3)   accelerometer increments, b frame: float64 m/s, or int32
                          counts with attr pulse_weight (3,) in m/s
    /steps/kind  (s,)     hold | rotate | spin
    /steps/label (s,)     position name given in the scenario or log
    /steps/axis  (s,)     moving gimbal (outer = 0), -1 for a hold
    /steps/start_time, end_time (s,)    s
    /steps/start_index, stop_index (s,) IMU samples [start_index, stop_index)
                                        lie wholly inside the step
    /steps/angles_start, angles_end (s, g)  gimbal angles (rad), outer first
    /table                attrs: gimbals (names, outer first), axes (g, 3) unit
                          gimbal axes each in its parent frame, mat_n_base (3, 3)
                          table base to NED (base azimuth and tilt)
    /table/time  (m,)     s, encoder reading times
    /table/encoder (m, g) rad, encoder readings
    /import, /check       import-log only: import settings (attrs) and the stationary
                          check of each hold (inins.calibration.stationary)
    /truth/...            simulation only: time (m,), quat_nb (m, 4),
                          table_angles (m, g), mount_rotvec (m, 3),
                          gyro_bias (m, 3), accel_bias (m, 3); attrs: sensor
                          error parameters in SI and mat_tb0
"""

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from inins.core import pulses
from inins.core.records import TRUTH_SERIES, Step, StepKind, TableRecord
from inins.exceptions import InputError
from inins.results import Series

CHUNK_SAMPLES = 1 << 18
G = "g"
"""Placeholder in a row shape for the number of gimbals."""


@dataclass(frozen=True)
class DatasetSpec:
    """One dataset of the layout: dtype, row shape (``"g"``: one per gimbal), units,
    frame and description."""

    dtype: str
    row_shape: tuple
    units: str
    frame: str
    description: str

    def shape(self, n_gimbals):
        """The row shape with the gimbal count filled in."""
        return tuple(n_gimbals if d == G else d for d in self.row_shape)


LAYOUT = {
    "imu/dtheta": DatasetSpec("float64", (3,), "rad", "b", "IMU dtheta increments per sample"),
    "imu/dv": DatasetSpec("float64", (3,), "m/s", "b", "IMU dv increments per sample"),
    "steps/kind": DatasetSpec("S8", (), "1", "", "hold, rotate or spin"),
    "steps/label": DatasetSpec(
        "S32",
        (),
        "1",
        "",
        "position label given in the scenario or log, or found from the encoders",
    ),
    "steps/axis": DatasetSpec(
        "int32", (), "1", "", "moving gimbal index (outer = 0), -1 for a hold"
    ),
    "steps/start_time": DatasetSpec("float64", (), "s", "", "step start"),
    "steps/end_time": DatasetSpec("float64", (), "s", "", "step end"),
    "steps/start_index": DatasetSpec(
        "int64", (), "1", "", "first IMU sample starting at or after the start"
    ),
    "steps/stop_index": DatasetSpec(
        "int64", (), "1", "", "one past the last IMU sample ending by the end"
    ),
    "steps/angles_start": DatasetSpec(
        "float64", (G,), "rad", "t", "gimbal angles at the step start"
    ),
    "steps/angles_end": DatasetSpec("float64", (G,), "rad", "t", "gimbal angles at the step end"),
    "table/time": DatasetSpec("float64", (), "s", "", "time of the encoder readings"),
    "table/encoder": DatasetSpec(
        "float64", (G,), "rad", "t", "encoder readings, outer gimbal first"
    ),
    "truth/time": DatasetSpec("float64", (), "s", "", "time of the truth samples"),
    "truth/quat_nb": DatasetSpec(
        "float64", (4,), "1", "nb", "true attitude quaternion, scalar first"
    ),
    "truth/table_angles": DatasetSpec(
        "float64", (G,), "rad", "t", "true gimbal angles, outer first"
    ),
    "truth/mount_rotvec": DatasetSpec("float64", (3,), "rad", "b", "mount rotation vector"),
    "truth/gyro_bias": DatasetSpec(
        "float64", (3,), "rad/s", "b", "total gyro bias, mean over the interval"
    ),
    "truth/accel_bias": DatasetSpec(
        "float64", (3,), "m/s^2", "b", "total accel bias, mean over the interval"
    ),
}
"""Every dataset of the layout. IMU increments quantized to pulses are stored as int32
counts (units ``count``) with a ``pulse_weight`` attribute (3,) in rad or m/s."""

STEP_FIELDS = (
    "kind",
    "label",
    "axis",
    "start_time",
    "end_time",
    "start_index",
    "stop_index",
    "angles_start",
    "angles_end",
)
"""The ``/steps`` datasets, one per :class:`inins.core.records.Step` field, in order."""


def series(path, data, n_gimbals=0, description=None):
    """A :class:`inins.results.Series` of layout dataset ``path`` holding ``data``."""
    spec = LAYOUT[path]
    data = np.asarray(data, dtype=spec.dtype)
    data = data.reshape(len(data), *spec.shape(n_gimbals))
    return Series(data, spec.units, spec.frame, description or spec.description)


def declare(
    sink, n_gimbals, pulse_weights=(None, None), truth=False, expected=(None, None), encoder=True
):
    """Create the streamed datasets (IMU increments, encoder, optionally truth) in ``sink``.

    Parameters
    ----------
    sink : inins.results.SeriesSink
    n_gimbals : int
    pulse_weights : (ndarray or None, ndarray or None)
        Gyro (rad) and accelerometer (m/s) pulse weights (3,) where the increments are
        stored as int32 pulse counts, else None (float64 in SI).
    truth : bool
        Also the ``/truth`` datasets (simulation).
    expected : (int or None, int or None)
        Expected rows of the IMU and of the encoder/truth series (chunking hint).
    encoder : bool
        Also the ``/table`` encoder series (False: a log without table angles).
    """
    for path, weight in zip(("imu/dtheta", "imu/dv"), pulse_weights, strict=True):
        spec = LAYOUT[path]
        if weight is None:
            sink.create(
                path,
                spec.row_shape,
                spec.dtype,
                spec.units,
                spec.frame,
                spec.description,
                expected_rows=expected[0],
            )
        else:
            sink.create(
                path,
                spec.row_shape,
                np.int32,
                "count",
                spec.frame,
                spec.description.replace("increments", "pulse counts"),
                expected_rows=expected[0],
                attrs={"pulse_weight": np.asarray(weight)},
            )
    paths = ["table/time", "table/encoder"] if encoder else []
    if truth:
        paths = [f"truth/{name}" for name in TRUTH_SERIES] + paths
    for path in paths:
        spec = LAYOUT[path]
        sink.create(
            path,
            spec.shape(n_gimbals),
            spec.dtype,
            spec.units,
            spec.frame,
            spec.description,
            expected_rows=expected[1],
        )


def append_chunk(sink, chunk, pulse_weights=(None, None), stored=(None, None), encoder=True):
    """Write a :class:`inins.core.records.TableChunk` into datasets made by :func:`declare`.

    ``stored`` may hold the IMU rows exactly as to be stored (a log's own pulse
    counts); otherwise quantized increments are turned into counts here.
    """
    for path, rows, weight, given in zip(
        ("imu/dtheta", "imu/dv"), (chunk.dtheta, chunk.dv), pulse_weights, stored, strict=True
    ):
        if given is not None:
            rows = given
        elif weight is not None:
            rows = pulses.counts_from_increments(rows, weight)
        sink.append(path, rows)
    if chunk.truth is not None:
        for name in TRUTH_SERIES:
            sink.append(f"truth/{name}", getattr(chunk.truth, name))
    if encoder:
        sink.append("table/time", chunk.encoder_time)
        sink.append("table/encoder", chunk.encoder)


def encode_steps(steps, n_gimbals):
    """The step schedule as ``/steps`` datasets: ``{path: Series}``."""
    columns = {name: [getattr(s, name) for s in steps] for name in STEP_FIELDS}
    columns["kind"] = [str(k).encode() for k in columns["kind"]]
    columns["label"] = [label.encode() for label in columns["label"]]
    return {
        f"steps/{name}": series(f"steps/{name}", values, n_gimbals)
        for name, values in columns.items()
    }


def decode_steps(columns):
    """Steps from the ``/steps`` columns (``{field: array}``, any mapping of arrays)."""

    def text(v):
        return v.decode() if isinstance(v, bytes) else str(v)

    n = len(columns["kind"])
    return tuple(
        Step(
            StepKind(text(columns["kind"][i])),
            text(columns["label"][i]),
            int(columns["axis"][i]),
            float(columns["start_time"][i]),
            float(columns["end_time"][i]),
            int(columns["start_index"][i]),
            int(columns["stop_index"][i]),
            columns["angles_start"][i],
            columns["angles_end"][i],
        )
        for i in range(n)
    )


@dataclass(frozen=True)
class TableData(TableRecord):
    """A table-data file: a :class:`inins.core.records.TableRecord` whose IMU
    increments are read in chunks from disk."""

    path: Path = None
    length: int = 0

    @property
    def n_samples(self):
        """Number of IMU samples."""
        return self.length

    def imu(self, start=0, stop=None):
        """Increments of samples [start, stop) in SI: dtheta (rad), dv (m/s), each (k, 3)."""
        stop = self.n_samples if stop is None else stop
        with h5py.File(self.path, "r") as f:
            return _read_si(f["imu/dtheta"], start, stop), _read_si(f["imu/dv"], start, stop)

    def imu_chunks(self, start=0, stop=None, chunk=CHUNK_SAMPLES):
        """Yield ``(k0, dtheta, dv)`` over samples [start, stop) in chunks, SI units.

        The next chunk is read and decompressed on a second thread while the caller
        works on the current one (the numba kernels release the GIL).
        """
        stop = self.n_samples if stop is None else stop
        starts = range(start, stop, chunk)
        with h5py.File(self.path, "r") as f, ThreadPoolExecutor(1) as pool:

            def read(k0):
                k1 = min(stop, k0 + chunk)
                return k0, _read_si(f["imu/dtheta"], k0, k1), _read_si(f["imu/dv"], k0, k1)

            pending = pool.submit(read, starts[0]) if starts else None
            for k0 in starts[1:]:
                current, pending = pending.result(), pool.submit(read, k0)
                yield current
            if pending is not None:
                yield pending.result()


def _read_si(dset, k0, k1):
    rows = dset[k0:k1]
    if "pulse_weight" in dset.attrs:
        return pulses.increments_from_counts(rows, dset.attrs["pulse_weight"])
    return rows.astype(np.float64, copy=False)


def _require(f, path, name):
    if path not in f:
        raise InputError(f"not a table-data file: missing {path}", source=name, key=path)
    return f[path]


def _text(values):
    return tuple(v.decode() if isinstance(v, bytes) else str(v) for v in values)


def _reader(name):
    def read(self):
        with h5py.File(self.path, "r") as f:
            return f[f"truth/{name}"][()]

    read.__doc__ = f"``/truth/{name}``, read from the file when asked (not kept)."
    return read


class FileTruth:
    """The ``/truth`` group of a table-data file with the attributes of
    :class:`inins.core.records.Truth`, each series read from the file when asked and
    not kept: a method holds only what it uses, while it uses it (calibrate-bias
    interpolates the quaternion at one time), so memory grows less with the record."""

    def __init__(self, path, attrs):
        self.path = path
        self.attrs = attrs

    time = property(_reader("time"))
    quat_nb = property(_reader("quat_nb"))
    table_angles = property(_reader("table_angles"))
    mount_rotvec = property(_reader("mount_rotvec"))
    gyro_bias = property(_reader("gyro_bias"))
    accel_bias = property(_reader("accel_bias"))


def _truth(f, path):
    if "truth" not in f:
        return None
    return FileTruth(path, dict(f["truth"].attrs))


def read_table_data(path):
    """Open a table-data file, check it (:func:`validate`) and read everything but the
    IMU increments.

    Raises
    ------
    InputError
        The file is missing, a directory, not HDF5, lacks part of the layout, or holds
        data of the wrong shape, type or values (naming the dataset).
    """
    path = Path(path)
    if path.is_dir():
        raise InputError("is a directory, expected a table-data HDF5 file", source=str(path))
    if not path.is_file():
        raise InputError("file not found", source=str(path))
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"cannot read as HDF5 ({exc})", source=str(path)) from None
    with f:
        name = str(path)
        try:
            return _read(f, path, name)
        except (KeyError, ValueError, TypeError, IndexError, OSError) as exc:
            raise InputError(
                f"not a readable table-data file ({type(exc).__name__}: {exc})", source=name
            ) from None


def _read(f, path, name):
    imu = _require(f, "imu", name)
    n = validate(f, name)
    site = _require(f, "site", name).attrs
    table = _require(f, "table", name)
    steps = _require(f, "steps", name)
    return TableData(
        t0=float(imu.attrs["t0_s"]),
        dt=float(imu.attrs["dt_s"]),
        lla=np.array([site["lat_rad"], site["lon_rad"], site["height_m"]], dtype=float),
        gimbals=_text(table.attrs["gimbals"]),
        axes=np.asarray(table.attrs["axes"], dtype=float).reshape(-1, 3),
        mat_n_base=np.asarray(table.attrs["mat_n_base"], dtype=float).reshape(3, 3),
        steps=decode_steps({k: steps[k][()] for k in STEP_FIELDS}),
        encoder_time=table["time"][()],
        encoder=table["encoder"][()],
        truth=_truth(f, path),
        source=name,
        path=path,
        length=n,
    )


def _bad(name, key, message):
    return InputError(message, source=name, key=key)


IMU_LIMITS = {"imu/dtheta": np.pi, "imu/dv": 1000.0}
"""Largest plausible increment per sample (rad, m/s): half a turn, 1000 m/s."""
MAX_ABS = 1e12
"""Largest magnitude of any other number in the layout (times in s, angles in rad)."""


def _numeric(f, key, name, shape_tail, finite=True, chunk=CHUNK_SAMPLES):
    """The dataset ``key``: numeric, rows of ``shape_tail``, every value finite (and for
    IMU increments within :data:`IMU_LIMITS`)."""
    dset = _require(f, key, name)
    if not isinstance(dset, h5py.Dataset) or dset.dtype.kind not in "iuf":
        raise _bad(
            name, key, f"expected a numeric dataset, got {getattr(dset, 'dtype', 'a group')}"
        )
    if dset.ndim != 1 + len(shape_tail) or tuple(dset.shape[1:]) != tuple(shape_tail):
        want = "x".join(["n", *map(str, shape_tail)])
        raise _bad(name, key, f"expected shape ({want}), got {dset.shape}")
    limit = IMU_LIMITS.get(key, MAX_ABS if dset.dtype.kind == "f" else None)
    if finite and (dset.dtype.kind == "f" or limit is not None):
        for k0 in range(0, dset.shape[0], chunk):
            rows = dset[k0 : k0 + chunk]
            bad = ~np.isfinite(rows)
            if bad.any():
                row = k0 + int(np.argwhere(bad)[0][0])
                raise _bad(name, key, f"row {row} is not finite (NaN or infinity)")
            if limit is not None:
                _within(dset, rows, k0, limit, key, name)
    return dset


def _within(dset, rows, k0, limit, key, name):
    weight = dset.attrs.get("pulse_weight")
    with np.errstate(all="ignore"):
        si = np.abs(rows * np.asarray(weight, float)) if weight is not None else np.abs(rows)
    bad = ~(si <= limit)
    if bad.any():
        row = k0 + int(np.argwhere(bad)[0][0])
        unit = LAYOUT[key].units if key in LAYOUT else ""
        raise _bad(name, key, f"row {row} exceeds {limit:g} {unit} in magnitude")


def _finite_attr(obj, attr, key, name, positive=False):
    if attr not in obj.attrs:
        raise _bad(name, key, f"missing attribute {attr}")
    try:
        value = np.asarray(obj.attrs[attr], dtype=float)
    except (TypeError, ValueError):
        raise _bad(name, key, f"attribute {attr} is not a number") from None
    if not np.all(np.isfinite(value)) or (positive and not np.all(value > 0)):
        raise _bad(name, key, f"attribute {attr} must be finite{' and > 0' if positive else ''}")
    return value


def validate(f, name) -> int:
    """Check an open table-data file against :data:`LAYOUT`; return the sample count.

    Shapes and dtypes of the IMU, step and encoder datasets, finite values (IMU
    increments, pulse weights, times, angles), ``dt_s > 0``, encoder times and step
    times non-decreasing, step sample ranges inside the record.

    Raises
    ------
    InputError
        Naming the file and the dataset (or attribute) at fault.
    """
    imu = _require(f, "imu", name)
    for attr in ("t0_s", "dt_s"):
        _finite_attr(imu, attr, "imu", name, positive=attr == "dt_s")
    lengths = set()
    for key in ("imu/dtheta", "imu/dv"):
        dset = _require(f, key, name)
        if isinstance(dset, h5py.Dataset) and "pulse_weight" in dset.attrs:
            w = _finite_attr(dset, "pulse_weight", key, name)
            if w.shape != (3,):
                raise _bad(name, key, f"pulse_weight must be 3 numbers, got shape {w.shape}")
        elif isinstance(dset, h5py.Dataset) and dset.dtype.kind in "iu":
            raise _bad(name, key, f"integer counts ({dset.dtype}) need a pulse_weight attribute")
        lengths.add(_numeric(f, key, name, (3,)).shape[0])
    if len(lengths) != 1:
        raise _bad(name, "imu", "imu/dtheta and imu/dv differ in length")
    n = lengths.pop()
    site = _require(f, "site", name)
    for attr in ("lat_rad", "lon_rad", "height_m"):
        _finite_attr(site, attr, "site", name)
    table = _require(f, "table", name)
    for attr in ("gimbals", "axes", "mat_n_base"):
        if attr not in table.attrs:
            raise _bad(name, "table", f"missing attribute {attr}")
    g = len(table.attrs["gimbals"])
    axes = _finite_attr(table, "axes", "table", name)
    if axes.size != 3 * g:
        raise _bad(name, "table", f"axes must be {g}x3 for {g} gimbals, got {axes.shape}")
    if _finite_attr(table, "mat_n_base", "table", name).size != 9:
        raise _bad(name, "table", "mat_n_base must be 3x3")
    _monotonic(_numeric(f, "table/time", name, ())[()], "table/time", name)
    if _numeric(f, "table/encoder", name, (g,)).shape[0] != f["table/time"].shape[0]:
        raise _bad(name, "table/encoder", "not as long as table/time")
    _validate_steps(f, name, n, g)
    if "truth" in f:
        _validate_truth(f, name, g)
    return n


def _validate_truth(f, name, g):
    """The simulation truth: shapes as in :data:`LAYOUT`, one length, finite."""
    lengths = set()
    for key in TRUTH_SERIES:
        path = f"truth/{key}"
        lengths.add(_numeric(f, path, name, LAYOUT[path].shape(g)).shape[0])
    if len(lengths) != 1:
        raise _bad(name, "truth", "the truth datasets differ in length")
    _monotonic(f["truth/time"][()], "truth/time", name)
    norms = np.linalg.norm(f["truth/quat_nb"][()], axis=1)
    if norms.size and np.max(np.abs(norms - 1.0)) > 1e-6:
        raise _bad(name, "truth/quat_nb", "quaternions must have unit norm")


def _monotonic(values, key, name):
    if values.size > 1 and np.any(np.diff(values) < 0):
        row = int(np.argmax(np.diff(values) < 0)) + 1
        raise _bad(name, key, f"times must not decrease (row {row})")


def _validate_steps(f, name, n, g):
    for field in STEP_FIELDS:
        _require(f, f"steps/{field}", name)
    counts = {f[f"steps/{field}"].shape[:1] for field in STEP_FIELDS}
    if len(counts) != 1:
        raise _bad(name, "steps", "the steps datasets differ in length")
    for field in ("start_time", "end_time"):
        _numeric(f, f"steps/{field}", name, ())
    for field in ("angles_start", "angles_end"):
        _numeric(f, f"steps/{field}", name, (g,))
    for field in ("axis", "start_index", "stop_index"):
        _numeric(f, f"steps/{field}", name, ())
    start, stop = f["steps/start_index"][()], f["steps/stop_index"][()]
    if np.any(start < 0) or np.any(stop > n) or np.any(stop < start):
        raise _bad(name, "steps/start_index", f"step sample ranges must lie within 0..{n}")
    t_start, t_end = f["steps/start_time"][()], f["steps/end_time"][()]
    if np.any(t_end < t_start):
        raise _bad(name, "steps/end_time", "a step ends before it starts")
    _monotonic(t_start, "steps/start_time", name)
    t0, dt = float(f["imu"].attrs["t0_s"]), float(f["imu"].attrs["dt_s"])
    first = np.ceil((t_start - t0) / dt - 1e-6)
    last = np.floor((t_end - t0) / dt + 1e-6)
    if np.any(np.abs(np.clip(first, 0, n) - start) > 1) or np.any(
        np.abs(np.clip(last, 0, n) - stop) > 1
    ):
        raise _bad(name, "steps/start_time", "step times and sample indices disagree (t0_s, dt_s)")
    axis = f["steps/axis"][()]
    if np.any((axis < -1) | (axis >= g)):
        raise _bad(name, "steps/axis", f"gimbal index must be -1..{g - 1}")
    kinds = {v.decode() if isinstance(v, bytes) else str(v) for v in f["steps/kind"][()]}
    if not kinds <= {k.value for k in StepKind}:
        raise _bad(
            name, "steps/kind", f"unknown step kinds {sorted(kinds - {'hold', 'rotate', 'spin'})}"
        )
