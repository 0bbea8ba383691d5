"""``inins simulate-table``: an IMU on a rate table (spec §3). See :mod:`inins.table.simulate`."""

import numpy as np

from inins.io.scenarios.simulate_table import SimulateTableScenario
from inins.table.simulate import run_simulation

SCENARIO_MODEL = SimulateTableScenario


def run(model, seed, sink, progress=None):
    """Simulate the scenario, streaming the table-data layout into ``sink``."""
    return run_simulation(model.to_si(), np.random.default_rng(seed), sink, progress)
