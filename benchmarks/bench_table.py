"""Rate-table IMU simulator throughput: exact increments from the table kinematics,
disturbances and the full sensor error model, on one core (no file writing).
"""

import resource
import time
from pathlib import Path

import numpy as np
import yaml

from inins.scenario.si.table import table_simulation
from inins.scenario.simulate_table import SimulateTableScenario
from inins.table.simulate import simulation_chunks

SCENARIO = Path(__file__).parent / "scenarios" / "table1-2h-1khz.yaml"


def run():
    """Simulate the 2 h, 1 kHz Table 1 sequence in memory-bounded chunks."""
    model = SimulateTableScenario.model_validate(yaml.safe_load(SCENARIO.read_text()))
    sim = table_simulation(model)
    short = table_simulation(model.model_copy(update={"motion": model.motion[:2]}))
    for _ in simulation_chunks(short, np.random.default_rng(0)):  # JIT warm-up
        break
    start = time.perf_counter()
    for _ in simulation_chunks(sim, np.random.default_rng(1)):
        pass
    wall = time.perf_counter() - start
    return {
        "samples": sim.n_samples,
        "wall_s": wall,
        "msamples_per_s": sim.n_samples / wall / 1e6,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    }
