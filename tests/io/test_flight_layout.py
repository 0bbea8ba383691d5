"""The PSINS tc reader and the recorded-flight HDF5 layout (round trip, bad input)."""

from dataclasses import replace
from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.io

from inins.exceptions import InputError
from inins.gnss import ephemeris, measurements, spp
from inins.io import flight_layout
from inins.io.flight_layout import read_flight, write_flight
from inins.io.psins_tc import read_psins_tc

ROOT = Path(__file__).resolve().parents[2]
MAT = ROOT / "data" / "insgpseo_tc.mat"


@pytest.fixture(scope="module")
def flight():
    return read_psins_tc(MAT)


def test_psins_tc_arrays(flight):
    raw = scipy.io.loadmat(MAT)
    assert flight.imu_t0_sow == 185492.5 and flight.imu_t0_week == 2183
    assert flight.imu.dtheta.shape == (27280, 3)
    np.testing.assert_array_equal(flight.imu.time, raw["imu"][:, 6])
    order = np.argsort(raw["obss"][:, 0], kind="stable")
    np.testing.assert_array_equal(flight.gnss.range_rate, -raw["obss"][order, 5])
    np.testing.assert_array_equal(flight.gnss.carrier, raw["obss"][order, 3])
    assert flight.gnss.start[-1] == 10584 and len(flight.gnss.time) == 1707
    assert flight.gnss.time[0] == flight.imu_t0_sow - 1664.5
    eph = flight.ephemeris
    assert sorted(eph["prn"]) == [5, 10, 13, 15, 18, 23, 24, 27, 29, 32]  # health != 255
    assert (eph["week"] == 2183).all() and (eph["health"] == 0).all()
    np.testing.assert_array_equal(eph["sqrt_a"], raw["ephs"][eph["prn"] - 1, 12])


def test_mat_without_the_expected_arrays(tmp_path):
    raw = scipy.io.loadmat(MAT)
    no_ephs = tmp_path / "no_ephs.mat"
    scipy.io.savemat(no_ephs, {k: raw[k] for k in ("imu", "obss", "t0")})
    with pytest.raises(InputError, match="'ephs' missing") as err:
        read_psins_tc(no_ephs)
    assert err.value.key == "ephs" and err.value.source == str(no_ephs)
    narrow = tmp_path / "narrow.mat"
    scipy.io.savemat(
        narrow, {**{k: raw[k] for k in ("imu", "ephs", "t0")}, "obss": raw["obss"][:, :5]}
    )
    with pytest.raises(InputError, match="'obss' has shape"):
        read_psins_tc(narrow)
    text = tmp_path / "text.mat"
    text.write_text("not a mat file")
    with pytest.raises(InputError, match="MATLAB"):
        read_psins_tc(text)


def test_layout_round_trip_gives_the_same_solution(flight, tmp_path):
    path = tmp_path / "flight.h5"
    write_flight(path, flight)
    back = read_flight(path)
    for name in flight_layout.GnssRecord.__dataclass_fields__:
        np.testing.assert_array_equal(getattr(back.gnss, name), getattr(flight.gnss, name))
    for name in back.ephemeris.dtype.names:  # per field: NaN (no URA) equals NaN
        np.testing.assert_array_equal(back.ephemeris[name], flight.ephemeris[name])
    np.testing.assert_array_equal(back.imu.dv, flight.imu.dv)
    assert back.imu_t0_sow == flight.imu_t0_sow and back.source == flight.source
    with h5py.File(path) as f:
        assert f["gnss/obs/range_rate"].attrs["unit"] == "m/s"
        assert f["gnss/ephemeris/omega_dot"].attrs["unit"] == "rad/s"
    g = back.gnss
    fields = ("week", "time", "start", "prn", "pseudorange", "range_rate", "sigma", "snr", "signal")
    obs = measurements.make_observations(**{k: getattr(g, k) for k in fields})
    sol = spp.solve(measurements.attach_satellites(obs, ephemeris.from_columns(back.ephemeris)))
    assert np.count_nonzero(sol.n_used >= 5) == 1566


def test_gnss_only_flight_and_simulated_ephemeris(flight, tmp_path):
    path = tmp_path / "gnss_only.h5"
    eph = ephemeris.from_columns(flight.ephemeris)  # the gnss container is accepted too
    write_flight(
        path,
        replace(
            flight,
            imu=None,
            ephemeris=eph,
            iono_alpha=np.ones(4),
            iono_beta=np.zeros(4),
            reference_pos_e=np.arange(3.0),
        ),
    )
    back = read_flight(path)
    assert back.imu is None
    np.testing.assert_array_equal(back.iono_alpha, np.ones(4))
    np.testing.assert_array_equal(back.reference_pos_e, [0.0, 1.0, 2.0])


def test_bad_flight_files(flight, tmp_path):
    path = tmp_path / "f.h5"
    write_flight(path, flight)
    with h5py.File(path, "a") as f:
        del f["gnss/obs/pseudorange"]
    with pytest.raises(InputError, match="dataset missing") as err:
        read_flight(path)
    assert err.value.key == "gnss/obs/pseudorange"
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = 1
    with pytest.raises(InputError, match="not a recorded-flight file"):
        read_flight(other)
    with pytest.raises(InputError, match="not a readable HDF5"):
        read_flight(MAT)


def test_failed_write_leaves_no_file(flight, tmp_path):
    path = tmp_path / "f.h5"
    broken = replace(flight, gnss=replace(flight.gnss, prn=None))
    with pytest.raises(TypeError):
        write_flight(path, broken)
    assert list(tmp_path.iterdir()) == []


def test_layout_is_declared_once_and_matches_the_gnss_container():
    names = {f for f in measurements.Observations.__dataclass_fields__}
    gnss_names = {
        d.path.rsplit("/", 1)[-1] for d in flight_layout.DATASETS if d.path.startswith("gnss/")
    }
    assert names <= gnss_names and gnss_names - names == {"carrier"}
    text = "\n".join(flight_layout.layout_text())
    for d in flight_layout.DATASETS:
        assert d.path in text and d.unit in text


def test_a_simulation_is_written_like_a_recording(tmp_path):
    """Simulated observations (no carrier phase) go into the same layout."""
    from inins.core.units import DEG
    from inins.gnss import constellation, simulate

    eph = constellation.walker(2100, 0.0, 3600.0)
    t = np.arange(0.0, 60.0)
    pos, vel = simulate.static_receiver(37 * DEG, 127 * DEG, 50.0, len(t))
    rng = np.random.default_rng(0)
    obs, _ = simulate.simulate(eph, 2100, t, pos, vel, np.zeros(len(t)), np.zeros(len(t)), rng)
    record = flight_layout.RecordedFlight(
        gnss=obs,
        ephemeris=eph,
        imu=None,
        source="simulation",
        imu_t0_week=-1,
        imu_t0_sow=float("nan"),
        reference_pos_e=pos[0],
    )
    path = tmp_path / "sim.h5"
    write_flight(path, record)
    back = read_flight(path)
    np.testing.assert_array_equal(back.gnss.pseudorange, obs.pseudorange)
    assert np.isnan(back.gnss.carrier).all() and back.imu is None
    sol = spp.solve(
        measurements.attach_satellites(
            measurements.make_observations(
                **{
                    k: getattr(back.gnss, k)
                    for k in (
                        "week",
                        "time",
                        "start",
                        "prn",
                        "pseudorange",
                        "range_rate",
                        "sigma",
                        "snr",
                        "signal",
                    )
                }
            ),
            ephemeris.from_columns(back.ephemeris),
        )
    )
    err = np.linalg.norm(sol.pos - back.reference_pos_e, axis=1)
    assert np.median(err) < 5.0  # 1 m pseudorange noise
