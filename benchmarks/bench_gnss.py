"""GNSS layer speed: satellite states over a day, SPP over the ABPO day, RINEX reading.

``run()`` reports, each as the best of three after a warm-up (JIT compile or
cache load), wall time and process CPU time (the machine may be shared):

- ``states_*``: ephemeris selection and position, velocity, clock and drift of
  32 satellites at 1 Hz over 24 h (2,764,800 states; target < 1 s);
- ``spp_*``: satellite states at transmit time and single-point positioning of
  the 2,727 ABPO epochs (ionosphere-free, troposphere, fault test; target < 0.5 s);
- ``read_obs_*``: reading the gzip-compressed ABPO observation file (3 MB
  uncompressed; target < 0.5 s);
- ``states_all_*``: every satellite of the smartLoc mixed navigation file (GPS,
  GLONASS by RK4, Galileo, BeiDou; 79 satellites) at 1 Hz over 24 h (target < 3 s);
- ``read_obs_mixed_*``: a synthetic 24 h four-system RINEX 3.04 file at 30 s (a
  static receiver in Berlin, every satellite above 5 deg, eight codes per system:
  61,433 satellite rows, 8 MB; target < 0.5 s);
- ``spp_mixed_*``: satellite states and SPP of that day (2,880 epochs, one clock
  and three inter-system biases; target < 1 s);
- ``read_obs_24h_1hz_*`` (issue 34): that day at every second (each 30-s epoch's
  satellites for the 30 seconds from it; 1.8 M satellite records, 14.7 M values,
  240 MB), read with :func:`inins.io.rinex_obs.read_obs`: values (observations: one
  code of one satellite at one epoch; target >= 1 M/s) and records per second.
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


def run(quick=False):
    """Figures of the GNSS hot paths (seconds, and items per second); ``quick``: without
    the 24-h 1-Hz file."""
    obs_file = read_obs(DATA / "abpo0080.15o.gz")
    eph = ephemeris.from_columns(read_nav(DATA / "abpo0080.15n.gz").records)
    figures = {}
    wall, cpu = _best(_states())
    figures.update(states_32sat_1hz_24h_s=wall, states_cpu_s=cpu, states_per_s=2_764_800 / wall)
    wall, cpu = _best(_spp(obs_file, eph))
    figures.update(spp_abpo_day_s=wall, spp_cpu_s=cpu, spp_epochs_per_s=2727 / wall)
    wall, cpu = _best(lambda: read_obs(DATA / "abpo0080.15o.gz"))
    figures.update(read_obs_abpo_s=wall, read_obs_cpu_s=cpu)
    figures.update(run_multi())
    if not quick:
        figures.update(run_1hz())
    return figures


if __name__ == "__main__":
    for key, value in run().items():
        print(f"{key:>28}: {value:,.3f}")


# --------------------------------------------------------------------------------------
# Multi-GNSS (GPS, GLONASS, Galileo, BeiDou) from the smartLoc mixed navigation file

SMARTLOC = DATA / "smartloc"
BERLIN_E = np.array([3785108.11, 899901.49, 5037234.46])
"""The smartLoc drive's start (m, ECEF): a receiver that sees all four systems."""


def _mixed_nav():
    from inins.gnss import broadcast
    from inins.io.rinex_nav import read_navigation

    m = read_navigation(SMARTLOC / "BRDC00WRD_U_20161580000_01D_MN.rnx.gz", leap_seconds=17)
    return broadcast.from_records(m.records, m.glonass)


def _all_states(nav):
    """Every satellite of the file at 1 Hz over the day: the row of each (satellite, time)."""
    from inins.gnss import broadcast

    sats = np.unique(np.concatenate([nav.kepler.prn, nav.glonass.sat]))
    t = np.arange(86400.0) + 86400.0  # Monday 2016-06-06, GPS week 1900
    sat = np.repeat(sats, len(t))
    sow = np.tile(t, len(sats))

    def work():
        index = broadcast.select(nav, sat, 1900, sow)
        ok = index >= 0
        return broadcast.satellite_states(nav, sat[ok], index[ok], 1900, sow[ok])

    return work, len(sats)


def synthetic_day(nav, interval=30.0, mask_deg=5.0):
    """Observations of a static receiver in Berlin over 24 h (four systems, every satellite
    above ``mask_deg`` with a set): exact ranges + a 30 m clock + a 5 m GLONASS bias, as
    :class:`inins.gnss.measurements.Observations` (C1 only) and RINEX 3 columns."""
    from inins.gnss import broadcast, measurements, propagation

    sats = np.unique(np.concatenate([nav.kepler.prn, nav.glonass.sat]))
    t = 86400.0 + np.arange(0.0, 86400.0, interval)
    sat, sow = np.repeat(sats, len(t)), np.tile(t, len(sats))
    index = broadcast.select(nav, sat, 1900, sow - 0.075)
    states = broadcast.satellite_states(
        nav, sat[index >= 0], index[index >= 0], 1900, sow[index >= 0] - 0.075
    )
    sat, sow = sat[index >= 0], sow[index >= 0]
    rho, _, los, _ = propagation.geometry(states.pos, states.vel, BERLIN_E, np.zeros(3))
    el, _ = propagation.elevation_azimuth(los, np.broadcast_to(BERLIN_E, los.shape))
    up = el > np.radians(mask_deg)
    order = np.lexsort((sat[up], sow[up]))
    sat, sow = sat[up][order], sow[up][order]
    epoch_t, counts = np.unique(sow, return_counts=True)
    start = np.concatenate([[0], np.cumsum(counts)])
    first = measurements.make_observations(1900, epoch_t, start, sat, rho[up][order] + 30.0)
    for _ in range(2):  # exact ranges at the transmit time of the last pseudorange
        epochs = measurements.attach_satellites(first, nav)
        rng, *_ = propagation.geometry(epochs.sat_pos, epochs.sat_vel, BERLIN_E, np.zeros(3))
        glo = epochs.obs.prn // 100 == 1
        pr = rng + 30.0 + np.where(glo, 5.0, 0.0) - epochs.sat_clock
        first = measurements.make_observations(1900, epoch_t, epochs.obs.start, epochs.obs.prn, pr)
    return first


def _rinex3_day(obs, path):
    """Write the synthetic day as a mixed RINEX 3.04 file: per system the codes a geodetic
    receiver records (code, phase, Doppler, SNR on two bands)."""
    from inins.io.rinex_obs import write_obs_v3

    pr = obs.pseudorange[:, None]
    lam = 0.19
    base = {
        "C": pr,
        "L": pr / lam,
        "D": np.full_like(pr, -1234.567),
        "S": np.full_like(pr, 45.0),
    }
    codes = {
        "G": ("C1C", "L1C", "D1C", "S1C", "C2W", "L2W", "D2W", "S2W"),
        "R": ("C1C", "L1C", "D1C", "S1C", "C2P", "L2P", "D2P", "S2P"),
        "E": ("C1C", "L1C", "D1C", "S1C", "C5Q", "L5Q", "D5Q", "S5Q"),
        "C": ("C2I", "L2I", "D2I", "S2I", "C7I", "L7I", "D7I", "S7I"),
    }
    columns = {
        s: (
            c,
            np.concatenate(
                [base[code[0]] + (3.0 if k >= 4 else 0.0) for k, code in enumerate(c)], axis=1
            ),
        )
        for s, c in codes.items()
    }
    write_obs_v3(path, obs.week, obs.time, obs.start, obs.prn, columns)


def run_multi():
    """Figures of the multi-GNSS paths: reading a 24 h four-system RINEX 3 file at 30 s,
    the states of every satellite of the mixed file at 1 Hz for 24 h, SPP of the day."""
    import tempfile

    from inins.gnss import measurements, spp
    from inins.io.rinex_obs import read_obs

    nav = _mixed_nav()
    figures = {}
    work, n_sat = _all_states(nav)
    wall, cpu = _best(work)
    figures.update(states_all_systems_1hz_24h_s=wall, states_all_cpu_s=cpu, states_all_sats=n_sat)
    obs = synthetic_day(nav)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "BERL00DEU_R_20161580000_01D_30S_MO.rnx"
        _rinex3_day(obs, path)
        wall, cpu = _best(lambda: read_obs(path, "GREC"))
        figures.update(
            read_obs_mixed_day_s=wall,
            read_obs_mixed_cpu_s=cpu,
            read_obs_mixed_rows=len(obs.prn),
            read_obs_mixed_mb=path.stat().st_size / 1e6,
        )
    wall, cpu = _best(lambda: spp.solve(measurements.attach_satellites(obs, nav)))
    figures.update(spp_mixed_day_s=wall, spp_mixed_cpu_s=cpu, spp_mixed_epochs=obs.n_epochs)
    return figures


# --------------------------------------------------------------------------------------
# Issue 34: a 24-h 1-Hz four-system observation file (the synthetic day at every second)

CODES_1HZ = {
    "G": ("C1C", "L1C", "D1C", "S1C", "C2W", "L2W", "D2W", "S2W"),
    "R": ("C1C", "L1C", "D1C", "S1C", "C2P", "L2P", "D2P", "S2P"),
    "E": ("C1C", "L1C", "D1C", "S1C", "C5Q", "L5Q", "D5Q", "S5Q"),
    "C": ("C2I", "L2I", "D2I", "S2I", "C7I", "L7I", "D7I", "S7I"),
}


def _f14_3(values):
    """(n, 14) bytes of ``values`` written ``%14.3f`` (|value| < 1e9; the thousandths
    rounded half to even)."""
    k = np.round(np.abs(values) * 1000.0).astype(np.int64)
    digits = (k[:, None] // 10 ** np.arange(12, -1, -1, dtype=np.int64)) % 10
    out = np.full((len(k), 14), 32, np.uint8)
    out[:, :10] = digits[:, :10] + 48
    out[:, 10] = 46
    out[:, 11:] = digits[:, 10:] + 48
    lead = np.cumsum(digits[:, :9] != 0, axis=1) == 0  # zeros before the first digit
    out[:, :9][lead] = 32
    sign = np.clip(lead.sum(axis=1) - 1, 0, 8)  # the column before the first digit
    negative = values < 0
    out[np.flatnonzero(negative), sign[negative]] = 45
    return out


def write_1hz_day(obs30, path, block=3600):
    """Write ``obs30`` (the 30-s synthetic day) as a RINEX 3.04 file at 1 Hz: each 30-s
    epoch's satellites at the 30 seconds from it, their values growing by 0.01 a
    second; eight codes per system. Returns (records, values written (m, 8))."""
    letters = np.array([ord(s) for s in "GRECJ"], np.uint8)
    header = [f"{'3.04':>9}{'':11}{'OBSERVATION DATA':20}{'M':20}RINEX VERSION / TYPE"]
    for letter, codes in CODES_1HZ.items():
        header.append(
            f"{letter}  {len(codes):3d}{''.join(' ' + c for c in codes):54}SYS / # / OBS TYPES"
        )
    header.append(f"{'':60}END OF HEADER")
    counts30 = np.diff(obs30.start)
    base = obs30.pseudorange[:, None] + np.array([0, 1e7, -1234.5, 45, 3, 1e7 + 3, -999.25, 40])
    total = 0
    with open(path, "wb") as f:
        f.write(("\n".join(header) + "\n").encode())
        for lo in range(0, 86400, block):
            sec = np.arange(lo, lo + block)
            k30 = sec // 30
            counts = counts30[k30]
            rows = np.concatenate([np.arange(obs30.start[k], obs30.start[k + 1]) for k in k30])
            offset = np.repeat(sec % 30, counts) * 0.01
            values = base[rows] + offset[:, None]
            fields = _f14_3(values.ravel()).reshape(len(rows), 8, 14)
            text = np.full((len(rows), 132), 32, np.uint8)
            text[:, 0] = letters[obs30.prn[rows] // 100]
            text[:, 1] = 48 + obs30.prn[rows] % 100 // 10
            text[:, 2] = 48 + obs30.prn[rows] % 10
            text[:, 3:131].reshape(-1, 8, 16)[:, :, :14] = fields
            text[:, 131] = 10
            body = text.tobytes()
            ends = np.cumsum(counts) * 132
            parts = []
            for s, c, a, b in zip(sec.tolist(), counts.tolist(), (ends - counts * 132).tolist(),
                                  ends.tolist(), strict=True):  # fmt: skip
                epoch = f"> 2016 06 06 {s // 3600:02d} {s // 60 % 60:02d}{s % 60:11.7f}  0{c:3d}\n"
                parts += [epoch.encode(), body[a:b]]
            f.write(b"".join(parts))
            total += len(rows)
    return total


def run_1hz():
    """Reading a 24-h 1-Hz four-system RINEX 3 file (1.8 M satellite records, 14.7 M
    values, 8 codes per system): wall and CPU (best of two), records and values (the
    observations: one code of one satellite at one epoch) per second."""
    import tempfile

    from inins.io.rinex_obs import read_obs

    obs30 = synthetic_day(_mixed_nav())
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "BERL00DEU_R_20161580000_01D_01S_MO.rnx"
        records = write_1hz_day(obs30, path)
        walls, cpus = [], []
        for _ in range(2):
            w, c = time.perf_counter(), time.process_time()
            got = read_obs(path, "GREC")
            walls.append(time.perf_counter() - w)
            cpus.append(time.process_time() - c)
        size = path.stat().st_size
    if len(got.prn) != records or len(got.time) != 86400:
        raise RuntimeError(f"read {len(got.prn)} records of {records}")
    values = records * 8
    return {
        "read_obs_24h_1hz_s": min(walls),
        "read_obs_24h_1hz_cpu_s": min(cpus),
        "read_obs_24h_1hz_records": records,
        "read_obs_24h_1hz_mb": size / 1e6,
        "read_obs_24h_1hz_values_per_s": values / min(walls),
        "read_obs_24h_1hz_records_per_s": records / min(walls),
    }
