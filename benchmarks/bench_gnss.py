"""GNSS layer speed: satellite states over a day, SPP over the ABPO day, RINEX reading.

``run()`` reports, each as the best of three after a warm-up (JIT compile or
cache load), wall time and process CPU time (the machine may be shared):

- ``states_*``: ephemeris selection and position, velocity, clock and drift of
  32 satellites at 1 Hz over 24 h (2,764,800 states; target < 1 s);
- ``spp_*``: satellite states at transmit time and single-point positioning of
  the 2,727 ABPO epochs (ionosphere-free, troposphere, fault test; target < 0.5 s);
- ``read_obs_*``: reading the gzip-compressed ABPO observation file (3 MB
  uncompressed; target < 0.5 s).
"""

import time
from pathlib import Path

import numpy as np

from inins.gnss import constellation, ephemeris, measurements, orbit, spp
from inins.io.rinex_nav import read_nav
from inins.io.rinex_obs import observable, read_obs

DATA = Path(__file__).resolve().parents[1] / "data"
REPEAT = 3


def _best(func):
    func()  # warm-up: JIT compile or cache load, file cache
    walls, cpus = [], []
    for _ in range(REPEAT):
        w, c = time.perf_counter(), time.process_time()
        func()
        walls.append(time.perf_counter() - w)
        cpus.append(time.process_time() - c)
    return min(walls), min(cpus)


def _states():
    eph = constellation.walker(2000, 0.0, 86400.0, planes=8, per_plane=4)
    t = np.arange(86400.0)[:, None]
    prn = np.arange(1, 33)[None, :]

    def work():
        index = ephemeris.select(eph, prn, 2000, t)
        return orbit.satellite_states(eph, index, 2000, t)

    return work


def _spp(obs_file, eph):
    pr, signal = measurements.code_pseudorange(
        observable(obs_file, "P1"), observable(obs_file, "P2"), observable(obs_file, "C1")
    )
    obs = measurements.make_observations(
        obs_file.week, obs_file.time, obs_file.start, obs_file.prn, pr, signal=signal
    )

    def work():
        return spp.solve(measurements.attach_satellites(obs, eph))

    return work


def run():
    """Figures of the three GNSS hot paths (seconds, and items per second)."""
    obs_file = read_obs(DATA / "abpo0080.15o.gz")
    eph = ephemeris.from_columns(read_nav(DATA / "abpo0080.15n.gz").records)
    figures = {}
    wall, cpu = _best(_states())
    figures.update(states_32sat_1hz_24h_s=wall, states_cpu_s=cpu, states_per_s=2_764_800 / wall)
    wall, cpu = _best(_spp(obs_file, eph))
    figures.update(spp_abpo_day_s=wall, spp_cpu_s=cpu, spp_epochs_per_s=2727 / wall)
    wall, cpu = _best(lambda: read_obs(DATA / "abpo0080.15o.gz"))
    figures.update(read_obs_abpo_s=wall, read_obs_cpu_s=cpu)
    return figures


if __name__ == "__main__":
    for key, value in run().items():
        print(f"{key:>28}: {value:,.3f}")
