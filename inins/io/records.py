"""Table records for the methods: from a table-data file, or a simulation run in memory."""

import numpy as np

from inins.io.tabledata import read_table_data
from inins.results import MemorySink
from inins.table.record import memory_record
from inins.table.simulate import simulate_table, step_schedule


def load_record(data=None, simulate=None, seed=0, progress=None):
    """The :class:`inins.table.record.TableRecord` a scenario names.

    Parameters
    ----------
    data : Path, optional
        A table-data HDF5 file (read lazily, increments streamed from disk).
    simulate : inins.io.scenarios.simulate_table.TableSetup, optional
        A simulate-table scenario, simulated in memory with ``seed``.

    Returns
    -------
    record : TableRecord
    sensor : inins.core.imu.SensorErrors or None
        The simulated sensor errors (for the noise figures), None for a file.
    """
    if data is not None:
        return read_table_data(data), None
    sim = simulate.to_si()
    sink = MemorySink()
    simulate_table(sim, np.random.default_rng(seed), sink, progress)
    return memory_record(sim, sink, step_schedule(sim)), sim.sensor
