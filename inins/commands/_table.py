"""Rate-table scenarios into the methods' SI objects, the table record a scenario names,
the table-data layout of a simulation and the size estimate of a table run."""

import shutil
import tempfile
import weakref
from dataclasses import replace
from pathlib import Path

import numpy as np

from inins.commands.budget import Estimate
from inins.core.records import MemoryRecord
from inins.exceptions import InputError
from inins.io import tabledata
from inins.io.hdf5 import read_datasets
from inins.io.tabledata import read_table_data
from inins.results import CommandResult
from inins.scenario.si.table import table_simulation
from inins.table import simulate
from inins.table.simulate import CHUNK_SAMPLES


def load_record(data=None, setup=None, seed=0, progress=None):
    """The :class:`inins.core.records.TableRecord` a scenario names.

    Parameters
    ----------
    data : Path, optional
        A table-data HDF5 file (read lazily, increments streamed from disk).
    setup : inins.scenario.simulate_table.TableSetup, optional
        A simulate-table scenario, simulated in memory with ``seed``.

    Returns
    -------
    record : TableRecord
    sensor : inins.core.imu.SensorErrors or None
        The simulated sensor errors (for the noise figures), None for a file.
    """
    if data is not None:
        return read_table_data(data), None
    sim = table_simulation(setup)
    if sim.n_samples * BYTES_PER_SAMPLE > SPILL_BYTES:
        return spilled_record(setup, seed, progress), sim.sensor
    chunks = simulate.simulation_chunks(sim, np.random.default_rng(seed), progress)
    return memory_record(sim, chunks), sim.sensor


SPILL_BYTES = 32 << 20
"""A simulated record whose increments take more memory than this is written to a
temporary table-data file and read back in chunks, so that memory stays flat in the
record length (a 4-h hold at 1 kHz would otherwise hold 1.4 GB)."""
BYTES_PER_SAMPLE = 48  # dtheta and dv, float64
F8 = 8


def spilled_record(setup, seed, progress=None):
    """The simulation of ``setup`` written to a temporary table-data file (removed when
    the record is no longer referenced), as a :class:`inins.io.tabledata.TableData`.

    The same numbers as :func:`memory_record`: quantized increments go through pulse
    counts either way, others are stored as float64.
    """
    from inins.io.hdf5 import ResultsWriter

    sim = table_simulation(setup)
    folder = Path(tempfile.mkdtemp(prefix="inins-simulation-"))
    try:
        path = folder / "simulation.h5"
        with ResultsWriter(path) as h5:
            with h5.sink(threaded=True) as sink:
                stream(sim, np.random.default_rng(seed), sink, progress)
            attrs, datasets = table_layout(sim)
            h5.write_result(CommandResult("simulate-table", {}, datasets=datasets, attrs=attrs))
        record = replace(read_table_data(path), source="simulation")
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        raise
    weakref.finalize(record, shutil.rmtree, folder, ignore_errors=True)
    return record


def memory_record(sim, chunks):
    """The :class:`~inins.core.records.MemoryRecord` of a simulation's chunks."""
    traj = sim.trajectory
    return MemoryRecord.from_chunks(
        chunks,
        truth_attrs=truth_attrs(sim),
        t0=0.0,
        dt=sim.dt,
        lla=np.asarray(traj.lla, float),
        gimbals=tuple(sim.gimbal_names),
        axes=traj.axes,
        mat_n_base=traj.mat_n_base,
        steps=simulate.schedule(sim),
        source="simulation",
    )


def truth_attrs(sim):
    """The ``/truth`` attributes: mounting and sensor error parameters in SI."""
    return {
        "mat_tb0": sim.trajectory.mat_tb0,
        **{f"sensor.{k}": np.asarray(v, dtype=float) for k, v in vars(sim.sensor).items()},
    }


def table_layout(sim):
    """The table-data attributes and step datasets of a simulation (beside the
    series :func:`stream` writes): ``(attrs, datasets)``."""
    lla = sim.trajectory.lla
    attrs = {
        "site": {"lat_rad": lla[0], "lon_rad": lla[1], "height_m": lla[2]},
        "imu": {"t0_s": 0.0, "dt_s": sim.dt, "sample_rate_hz": sim.sample_rate},
        "table": {
            "gimbals": list(sim.gimbal_names),
            "axes": sim.trajectory.axes,
            "mat_n_base": sim.trajectory.mat_n_base,
        },
        "truth": {"truth_decimation": sim.truth_decimation, **truth_attrs(sim)},
    }
    datasets = tabledata.encode_steps(simulate.schedule(sim), len(sim.gimbal_names))
    return attrs, datasets


def stream(sim, rng, sink, progress=None):
    """Stream the simulation's IMU, encoder and truth series into ``sink`` in the
    table-data layout (pulse counts where the sensor is quantized)."""
    s = sim.sensor
    weights = tuple(
        w if np.any(w > 0) else None for w in (s.gyro_pulse_weight, s.accel_pulse_weight)
    )
    n_rows = sim.n_samples // sim.truth_decimation
    tabledata.declare(
        sink, len(sim.gimbal_names), weights, truth=True, expected=(sim.n_samples, n_rows)
    )
    for chunk in simulate.simulation_chunks(sim, rng, progress):
        try:
            tabledata.append_chunk(sink, chunk, weights)
        except ValueError as exc:
            if "overflow int32" not in str(exc):
                raise
            raise InputError(
                "the increments per sample exceed 2**31 pulses: the rates (motion, biases) "
                "are too large for the pulse weights",
                key="imu.gyro.pulse_weight_arcsec, imu.accel.pulse_weight_ug_s",
            ) from None
    return sink


def table_estimate(setup, in_memory: bool) -> Estimate:
    """Size of a rate-table simulation (a simulate-table scenario or a ``simulate:``
    section): IMU increments, truth and encoder rows.

    ``in_memory``: the record is kept in memory (calibrate-bias, align-ett) rather
    than streamed in chunks to the output (simulate-table).
    """
    try:
        sim = table_simulation(setup)
    except (ValueError, ArithmeticError) as exc:
        raise InputError(f"cannot build the motion program: {exc}", key="motion") from None
    n, d, g = sim.n_samples, sim.truth_decimation, len(sim.gimbal_names)
    keys = "imu.sample_rate_hz and the motion durations"
    if n <= 0:
        raise InputError(
            f"the motion program ({sim.trajectory.program.duration:g} s) is shorter than one "
            f"truth interval ({d} samples at {sim.sample_rate:g} Hz)",
            key="imu.sample_rate_hz / output.truth_rate_hz",
        )
    rows = n // d
    imu = n * 6 * F8
    series = rows * (1 + 4 + g + 3 + 3 + 3 + 1 + g) * F8
    chunk = min(n, CHUNK_SAMPLES)
    if in_memory and n * BYTES_PER_SAMPLE <= SPILL_BYTES:
        # chunks, then their concatenation; navigation works on the record
        return Estimate(n, 1 << 20, 3 * (imu + series), keys)
    if in_memory:  # spilled to a temporary table-data file, read back in chunks
        return Estimate(n, imu + series, 4 * chunk * 6 * F8 + series + (64 << 20), keys)
    return Estimate(n, imu + series, 4 * chunk * 6 * F8 + (64 << 20), keys)


ETT_DATASETS = (
    "mat_tb",
    "mat_tb0",
    "mu",
    "heading_rad",
    "heading_sigma_rad",
    "level_angles",
    "mat_n_base",
    "axes",
)
"""The datasets of the ``ett`` group of an ``align-ett.h5``."""


def read_ett_result(path):
    """The :class:`~inins.calibration.ett.EttResult` stored in an ``align-ett.h5``.

    Raises
    ------
    InputError
        Missing file, not HDF5, or no complete ``ett`` group.
    """
    from inins.calibration.ett import EttResult  # not loaded by simulate-table

    d = read_datasets(path, "ett", ETT_DATASETS, "an align-ett results file")
    return EttResult(
        mat_tb=d["mat_tb"],
        mat_tb0=d["mat_tb0"],
        mu=d["mu"],
        heading=float(d["heading_rad"]),
        heading_sigma=float(d["heading_sigma_rad"]),
        level_angles=d["level_angles"],
        mat_n_base=d["mat_n_base"],
        axes=d["axes"].reshape(-1, 3),
    )
