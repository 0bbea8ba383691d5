"""The recorded-flight HDF5 layout: IMU increments, per-epoch GNSS measurements and
broadcast ephemerides, so that a recording and a simulation look the same to run-ekf.

Declared once here (:data:`DATASETS`, :data:`EPHEMERIS_FIELDS`, :data:`ROOT_ATTRS`);
:func:`write_flight` and :func:`read_flight` follow the declaration, and
:func:`layout_text` prints it for the documentation.

Layout
------
``/`` attributes: ``layout`` = ``"inins-recorded-flight"``, ``layout_version``,
``source`` (what the data came from), ``imu_t0_sow`` (GPS seconds of week of
IMU time 0, NaN without IMU), ``imu_t0_week``, ``reference_pos_e`` (known
antenna ECEF position, m, or NaN: a static station), optional ``iono_alpha``,
``iono_beta`` (Klobuchar, from the navigation header).

``/gnss/epoch/*`` one row per epoch; ``/gnss/obs/*`` one row per satellite
measurement, rows of epoch ``k`` being ``start[k]:start[k + 1]``;
``/gnss/ephemeris/*`` one row per broadcast ephemeris set (Keplerian: GPS, Galileo,
BeiDou, QZSS); ``/gnss/glonass/*`` one row per GLONASS broadcast set (state vectors;
absent without GLONASS); ``/imu/*`` one row per IMU sample (absent without IMU).
"""

from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from inins.core.ephemeris_fields import FIELDS
from inins.exceptions import InputError
from inins.io.atomic import AtomicFile

LAYOUT = "inins-recorded-flight"
LAYOUT_VERSION = 1

EPHEMERIS_FIELDS = FIELDS
"""(name, dtype, unit, description) of ``/gnss/ephemeris/<name>``."""


GLONASS_FIELDS = (
    ("sat", "int64", "(n_glo,)", "", "satellite number 100 + GLONASS slot"),
    ("week", "int64", "(n_glo,)", "week", "GPS week of tb"),
    ("toe", "float64", "(n_glo,)", "s", "tb, GPS seconds of week"),
    ("clock_bias", "float64", "(n_glo,)", "s", "-tau_n (satellite clock at tb)"),
    ("gamma", "float64", "(n_glo,)", "1", "relative frequency bias gamma_n"),
    ("pos", "float64", "(n_glo, 3)", "m", "PZ-90.11 position at tb"),
    ("vel", "float64", "(n_glo, 3)", "m/s", "PZ-90.11 velocity at tb"),
    ("acc", "float64", "(n_glo, 3)", "m/s^2", "lunisolar acceleration at tb"),
    ("health", "int64", "(n_glo,)", "", "0 healthy"),
    ("channel", "int64", "(n_glo,)", "", "frequency channel k (-7 .. +6)"),
)
"""(name, dtype, shape, unit, description) of ``/gnss/glonass/<name>`` (optional group:
all or none; the fields of :class:`inins.gnss.glonass.GlonassEphemeris`)."""


@dataclass(frozen=True)
class Dataset:
    """One dataset of the layout: HDF5 path, dtype, shape, unit, meaning, required."""

    path: str
    dtype: str
    shape: str
    unit: str
    description: str
    required: bool = True


DATASETS = (
    Dataset("gnss/epoch/week", "int64", "(n_epochs,)", "week", "GPS week of the epoch"),
    Dataset(
        "gnss/epoch/time",
        "float64",
        "(n_epochs,)",
        "s",
        "receive time tag, GPS seconds of week (receiver clock)",
    ),
    Dataset(
        "gnss/epoch/start",
        "int64",
        "(n_epochs + 1,)",
        "",
        "rows of epoch k in gnss/obs are start[k]:start[k+1]",
    ),
    Dataset("gnss/obs/prn", "int64", "(m,)", "", "satellite PRN"),
    Dataset(
        "gnss/obs/pseudorange",
        "float64",
        "(m,)",
        "m",
        "pseudorange (signal says which: 1 L1 C/A or P1, 2 ionosphere-free P1/P2)",
    ),
    Dataset("gnss/obs/signal", "int8", "(m,)", "", "1 = L1 (TGD applies), 2 = ionosphere-free"),
    Dataset(
        "gnss/obs/range_rate",
        "float64",
        "(m,)",
        "m/s",
        "range rate, positive when the range grows (= -Doppler * lambda_L1); NaN absent",
    ),
    Dataset(
        "gnss/obs/sigma",
        "float64",
        "(m,)",
        "m",
        "pseudorange 1-sigma stated by the source; NaN absent",
    ),
    Dataset("gnss/obs/snr", "float64", "(m,)", "dB-Hz", "signal strength; NaN absent"),
    Dataset(
        "gnss/obs/carrier",
        "float64",
        "(m,)",
        "m",
        "L1 carrier phase in metres (arbitrary offset); NaN absent",
        required=False,
    ),
    Dataset(
        "imu/time",
        "float64",
        "(n,)",
        "s",
        "IMU time of the end of each increment; GPS sow = imu_t0_sow + time",
        False,
    ),
    Dataset("imu/dtheta", "float64", "(n, 3)", "rad", "angle increments, body frame", False),
    Dataset("imu/dv", "float64", "(n, 3)", "m/s", "velocity increments, body frame", False),
)
"""Every dataset of the layout besides ``gnss/ephemeris/<field>``."""

ROOT_ATTRS = (
    ("layout", "str", "", "always 'inins-recorded-flight'"),
    ("layout_version", "int", "", "version of this layout"),
    ("source", "str", "", "what the data came from (file names, simulation)"),
    ("imu_t0_week", "int", "week", "GPS week of IMU time 0 (-1 without IMU)"),
    ("imu_t0_sow", "float", "s", "GPS seconds of week of IMU time 0 (NaN without IMU)"),
    ("reference_pos_e", "float (3,)", "m", "known ECEF antenna position, NaN if none"),
    ("iono_alpha", "float (4,)", "s, s/sc, s/sc^2, s/sc^3", "Klobuchar alpha (optional)"),
    ("iono_beta", "float (4,)", "s, s/sc, s/sc^2, s/sc^3", "Klobuchar beta (optional)"),
)


@dataclass(frozen=True)
class GnssRecord:
    """The ``gnss/epoch`` and ``gnss/obs`` datasets (names and units as in :data:`DATASETS`).

    Field names are those of :class:`inins.gnss.measurements.Observations` (plus
    ``carrier``), so ``make_observations(**...)`` turns one into the other.
    """

    week: np.ndarray
    time: np.ndarray
    start: np.ndarray
    prn: np.ndarray
    pseudorange: np.ndarray
    signal: np.ndarray
    range_rate: np.ndarray
    sigma: np.ndarray
    snr: np.ndarray
    carrier: np.ndarray


@dataclass(frozen=True)
class ImuRecord:
    """IMU increments: ``time`` (n,) s, ``dtheta`` (n, 3) rad, ``dv`` (n, 3) m/s, body frame."""

    time: np.ndarray
    dtheta: np.ndarray
    dv: np.ndarray


@dataclass(frozen=True)
class RecordedFlight:
    """A recorded (or simulated) flight as stored in the layout.

    ``ephemeris`` is a structured array of :data:`EPHEMERIS_FIELDS`; ``imu`` is
    None without IMU data; ``reference_pos_e`` is NaN (3,) when unknown.
    """

    gnss: GnssRecord
    ephemeris: np.ndarray
    imu: ImuRecord | None
    source: str
    imu_t0_week: int
    imu_t0_sow: float
    reference_pos_e: np.ndarray
    iono_alpha: np.ndarray | None = None
    iono_beta: np.ndarray | None = None
    glonass: dict | None = None
    """GLONASS sets: ``{name: array}`` of :data:`GLONASS_FIELDS` (None: none)."""
    dropped: tuple = ()
    """What the edge checks dropped (counted), one line each
    (:func:`inins.io.flight_checks.checked_flight`); the commands report it."""


def layout_text():
    """The layout as text lines (path, dtype, shape, unit, description)."""
    rows = [
        f"/{d.path:24s} {d.dtype:8s} {d.shape:16s} {d.unit:6s} {d.description}" for d in DATASETS
    ]
    rows += [
        f"/gnss/ephemeris/{n:9s} {dt:8s} {'(n_sets,)':16s} {u:6s} {desc}"
        for n, dt, u, desc in EPHEMERIS_FIELDS
    ]
    rows += [
        f"/gnss/glonass/{n:11s} {dt:8s} {shape:16s} {u:6s} {desc}"
        for n, dt, shape, u, desc in GLONASS_FIELDS
    ]
    rows += [f"@{n:24s} {dt:25s} {u:6s} {desc}" for n, dt, u, desc in ROOT_ATTRS]
    return rows


def ephemeris_array(eph):
    """Structured array of :data:`EPHEMERIS_FIELDS` from anything with those attributes
    or fields (an :class:`inins.gnss.ephemeris.Ephemeris`, a structured array)."""

    def get(name):
        return eph[name] if isinstance(eph, np.ndarray) else getattr(eph, name)

    n = len(get("prn"))
    out = np.zeros(n, dtype=[(name, dt) for name, dt, _, _ in EPHEMERIS_FIELDS])
    for name, *_ in EPHEMERIS_FIELDS:
        out[name] = get(name)
    return out


def flight_arrays(flight):
    """The layout's datasets of a :class:`RecordedFlight`: ``{path: (array, unit,
    description)}``, absent optional datasets left out.

    ``flight.gnss`` may be any object with the attributes of :class:`GnssRecord`
    (``carrier`` optional, e.g. :class:`inins.gnss.measurements.Observations` of a
    simulation) and ``flight.ephemeris`` anything :func:`ephemeris_array` takes.
    """
    out = {}
    for d in DATASETS:
        group, name = d.path.split("/", 1)
        record = flight.gnss if group == "gnss" else flight.imu
        value = None if record is None else getattr(record, name.rsplit("/", 1)[-1], None)
        if value is None and not d.required:
            continue  # no IMU, or a source without carrier phase
        out[d.path] = (np.asarray(value, dtype=d.dtype), d.unit, d.description)
    eph = ephemeris_array(flight.ephemeris)
    for name, dtype, unit, desc in EPHEMERIS_FIELDS:
        out[f"gnss/ephemeris/{name}"] = (eph[name].astype(dtype), unit, desc)
    glonass = getattr(flight, "glonass", None)
    if glonass is not None:
        for name, dtype, _, unit, desc in GLONASS_FIELDS:
            out[f"gnss/glonass/{name}"] = (np.asarray(glonass[name], dtype), unit, desc)
    return out


def glonass_columns(eph):
    """``{name: array}`` of :data:`GLONASS_FIELDS` from a GLONASS ephemeris object (its
    attributes), or None if it has no set."""
    if eph is None or len(eph.sat) == 0:
        return None
    return {name: np.asarray(getattr(eph, name), dtype) for name, dtype, *_ in GLONASS_FIELDS}


def _read_glonass(f, path):
    """The optional ``gnss/glonass`` group: None if absent; every field, finite, of one
    length and its shape, else bad input naming the dataset."""
    if "gnss/glonass" not in f:
        return None
    out, n = {}, None
    for name, dtype, shape, _, _ in GLONASS_FIELDS:
        key = f"gnss/glonass/{name}"
        if key not in f:
            raise InputError(
                "dataset missing (gnss/glonass needs all fields)", source=str(path), key=key
            )
        value = _read_dataset(f, key, dtype, path)
        width = (3,) if shape.endswith("3)") else ()
        n = len(value) if n is None else n
        if value.shape != (n, *width) or not np.all(np.isfinite(value)):
            raise InputError(
                f"has shape {value.shape}, expected ({n}{', 3' if width else ''},) finite values",
                source=str(path),
                key=key,
            )
        if np.dtype(dtype).kind == "i":
            if not np.all(value == np.round(value)):
                raise InputError("expected whole numbers", source=str(path), key=key)
            value = value.astype(dtype)
        out[name] = value
    return out


def flight_attrs(flight):
    """The layout's root attributes of a :class:`RecordedFlight`."""
    attrs = {
        "layout": LAYOUT,
        "layout_version": LAYOUT_VERSION,
        "source": flight.source,
        "imu_t0_week": int(flight.imu_t0_week),
        "imu_t0_sow": float(flight.imu_t0_sow),
        "reference_pos_e": np.asarray(flight.reference_pos_e, float),
    }
    for name in ("iono_alpha", "iono_beta"):
        if getattr(flight, name) is not None:
            attrs[name] = np.asarray(getattr(flight, name), float)
    return attrs


def write_flight(path, flight):
    """Write a :class:`RecordedFlight` to ``path`` (HDF5), atomically (the file appears
    under its name only when complete, :class:`~inins.io.atomic.AtomicFile`)."""
    with AtomicFile(path) as out, h5py.File(out.tmp, "w") as f:
        f.attrs.update(flight_attrs(flight))
        for path_in_file, (value, unit, description) in flight_arrays(flight).items():
            _dataset(f, path_in_file, value, unit, description)


def _dataset(f, path, value, unit, description):
    dset = f.create_dataset(path, data=value, compression="gzip" if value.size > 4096 else None)
    dset.attrs["unit"] = unit
    dset.attrs["description"] = description


def read_flight(path):
    """Read a file of the recorded-flight layout.

    The flight is checked by :func:`inins.io.flight_checks.checked_flight` (the same
    rules for every source): rows it drops are counted in ``dropped``.

    Raises
    ------
    InputError
        Not an HDF5 file of this layout or another version of it, a required dataset
        missing or not numbers (named), or data breaking the rules of
        :mod:`inins.io.flight_checks` (dataset and row named).
    """
    path = Path(path)
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"not a readable HDF5 file: {exc}", source=str(path)) from exc
    with f:
        if f.attrs.get("layout") != LAYOUT:
            raise InputError(
                f"not a recorded-flight file (layout attribute "
                f"{f.attrs.get('layout')!r}, expected {LAYOUT!r})",
                source=str(path),
                key="/",
            )
        version = f.attrs.get("layout_version")
        if version != LAYOUT_VERSION:
            shown = version.item() if isinstance(version, np.generic) else version
            raise InputError(
                f"layout_version {shown!r} is not {LAYOUT_VERSION}, the version this "
                "inins reads (written by another version of inins?)",
                source=str(path),
                key="/layout_version",
            )
        values = {}
        for d in DATASETS:
            if d.path in f:
                values[d.path] = _read_dataset(f, d.path, d.dtype, path)
            elif d.required:
                raise InputError("dataset missing", source=str(path), key=d.path)
        eph = np.zeros(0, dtype=[(n, dt) for n, dt, _, _ in EPHEMERIS_FIELDS])
        for name, dtype, _, _ in EPHEMERIS_FIELDS:
            key = f"gnss/ephemeris/{name}"
            if key not in f:
                raise InputError("dataset missing", source=str(path), key=key)
            column = _read_dataset(f, key, dtype, path)
            if column.ndim != 1:
                raise InputError(
                    f"has shape {column.shape}, expected (n_sets,)", source=str(path), key=key
                )
            if len(eph) and len(eph) != len(column):
                raise InputError(
                    f"has {len(column)} rows, the other ephemeris fields {len(eph)}",
                    source=str(path),
                    key=key,
                )
            if len(eph) != len(column):
                eph = np.zeros(len(column), dtype=eph.dtype)
            eph[name] = column
        attrs = {k: f.attrs[k] for k in f.attrs}
        glonass = _read_glonass(f, path)
    return _assemble(values, eph, attrs, path, glonass)


def _read_dataset(f, key, dtype, path):
    """A dataset as an array of ``dtype``; bad input if it is a group or not numbers
    (integer datasets may be read from floats, then checked for whole numbers)."""
    node = f[key]
    if not isinstance(node, h5py.Dataset):
        raise InputError("is a group, expected a dataset", source=str(path), key=key)
    try:
        raw = np.asarray(node[()])
        if raw.dtype.kind not in "biuf":
            raise TypeError(raw.dtype)
        if np.dtype(dtype).kind in "iu" and raw.dtype.kind == "f":
            return raw  # whole numbers and range checked with the rest
        return raw.astype(dtype)
    except (TypeError, ValueError, OSError):
        raise InputError(
            f"holds {np.asarray(node[()]).dtype} values, expected {dtype} numbers",
            source=str(path),
            key=key,
        ) from None


def _assemble(values, eph, attrs, path, glonass=None):
    from inins.io.flight_checks import checked_flight

    m = len(values["gnss/obs/prn"])
    carrier = values.get("gnss/obs/carrier", np.full(m, np.nan))
    gnss = GnssRecord(
        carrier=carrier,
        **{
            d.path.rsplit("/", 1)[-1]: values[d.path]
            for d in DATASETS
            if d.path.startswith("gnss/") and d.path != "gnss/obs/carrier"
        },
    )
    imu = None
    present = [k for k in ("imu/time", "imu/dtheta", "imu/dv") if k in values]
    if present and len(present) < 3:
        missing = next(k for k in ("imu/time", "imu/dtheta", "imu/dv") if k not in values)
        raise InputError(
            f"dataset missing (the IMU needs imu/time, imu/dtheta and imu/dv; "
            f"{', '.join(present)} found)",
            source=str(path),
            key=missing,
        )
    if present:
        imu = ImuRecord(time=values["imu/time"], dtheta=values["imu/dtheta"], dv=values["imu/dv"])
    try:
        flight = RecordedFlight(
            gnss=gnss,
            ephemeris=eph,
            imu=imu,
            source=str(attrs.get("source", "")),
            imu_t0_week=int(attrs.get("imu_t0_week", -1)),
            imu_t0_sow=float(np.asarray(attrs.get("imu_t0_sow", np.nan)).reshape(-1)[0]),
            reference_pos_e=_vector(attrs, "reference_pos_e", 3, path),
            iono_alpha=_optional_vector(attrs, "iono_alpha", path),
            iono_beta=_optional_vector(attrs, "iono_beta", path),
            glonass=glonass,
        )
    except (TypeError, ValueError, IndexError):
        raise InputError(
            "a root attribute (imu_t0_week, imu_t0_sow) is not a number", source=str(path), key="/"
        ) from None
    return checked_flight(flight, path)


def _vector(attrs, name, size, path):
    try:
        value = np.asarray(attrs.get(name, np.full(size, np.nan)), float).reshape(-1)
    except (TypeError, ValueError):
        value = np.zeros(0)
    if value.shape != (size,):
        raise InputError(f"expected {size} numbers", source=str(path), key=f"/{name}")
    return value


def _optional_vector(attrs, name, path):
    if name not in attrs:
        return None
    value = _vector(attrs, name, 4, path)
    if not np.isfinite(value).all():
        raise InputError("not finite", source=str(path), key=f"/{name}")
    return value
