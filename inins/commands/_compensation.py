"""Compensation files (written by ``inins calibrate-imu``) for any command that reads raw
increments: ``compensation_terms(path)`` gives the terms, and
:func:`inins.calibration.imu_model.compensate` applies them to raw increments.

A command that takes ``compensation: FILE`` (import-log, calibrate-bias, run-ekf) calls
``compensation_terms(scenario.compensation, unit_name, serial)`` and compensates each
chunk of increments it reads: ``dtheta, dv = imu_model.compensate(dtheta, dv, dt, terms)``;
:class:`CompensatedRecord` does so for a table record (calibrate-bias).
"""

import hashlib
from dataclasses import dataclass, fields
from pathlib import Path

from inins.calibration import imu_model
from inins.core.records import TableRecord
from inins.exceptions import InputError
from inins.io.tabledata import CHUNK_SAMPLES
from inins.scenario.si.compensation import terms_from_compensation


def compensation_terms(path, unit_name=None, serial=None):
    """The :class:`~inins.calibration.imu_model.ImuTerms` (SI) of a compensation file.

    Raises
    ------
    InputError
        The file is unreadable, not a compensation file, of another format version,
        or made for another unit (when ``unit_name`` / ``serial`` are given), naming
        the file and key.
    """
    from inins.scenario.base import load_scenario
    from inins.scenario.calibrate_imu import CompensationFile  # its scenario models: lazily

    try:
        comp = load_scenario(CompensationFile, path, [], None)[0]
    except InputError as exc:
        exc.source = exc.source or str(path)
        raise
    want = (unit_name, serial)
    have = (comp.unit.name, comp.unit.serial)
    if any(w is not None and w != h for w, h in zip(want, have, strict=True)):
        raise InputError(
            f"made for unit {have[0]} serial {have[1]}, not {unit_name} serial {serial} "
            "(unit.name, unit.serial)",
            source=str(path),
            key="unit",
        )
    return terms_from_compensation(comp)


def scenario_terms(scenario):
    """The terms of ``scenario.compensation`` (checked against
    ``scenario.compensation_serial`` when given), or None without one."""
    if scenario.compensation is None:
        return None
    return compensation_terms(scenario.compensation, None, scenario.compensation_serial)


def compensation_provenance(path):
    """Attributes naming the compensation file applied: its name and SHA-256."""
    digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
    return {"compensation_file": Path(path).name, "compensation_sha256": digest}


@dataclass(frozen=True)
class CompensatedRecord(TableRecord):
    """A :class:`~inins.core.records.TableRecord` whose increments are those of
    ``inner`` with :func:`~inins.calibration.imu_model.compensate` applied, chunk by
    chunk as they are read (so a file is never loaded whole)."""

    inner: TableRecord = None
    terms: imu_model.ImuTerms = None

    @classmethod
    def wrap(cls, record, terms):
        """``record`` itself without terms, else its compensated view."""
        if terms is None:
            return record
        meta = {f.name: getattr(record, f.name) for f in fields(TableRecord)}
        return cls(**meta, inner=record, terms=terms)

    @property
    def n_samples(self):
        """Number of IMU samples."""
        return self.inner.n_samples

    def imu(self, start=0, stop=None):
        """Compensated increments of samples [start, stop): dtheta (rad), dv (m/s)."""
        return imu_model.compensate(*self.inner.imu(start, stop), self.dt, self.terms)

    def imu_chunks(self, start=0, stop=None, chunk=CHUNK_SAMPLES):
        """Yield ``(k0, dtheta, dv)`` compensated, chunk by chunk."""
        for k0, dth, dv in self.inner.imu_chunks(start, stop, chunk):
            yield (k0, *imu_model.compensate(dth, dv, self.dt, self.terms))
