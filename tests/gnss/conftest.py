"""Shared real data of the GNSS tests: the packaged ABPO day and the PSINS tc file."""

from pathlib import Path

import numpy as np
import pytest

from inins.gnss import ephemeris, measurements, spp
from inins.io.psins_tc import read_psins_tc
from inins.io.rinex_nav import read_nav
from inins.io.rinex_obs import observable, read_obs

DATA = Path(__file__).resolve().parents[2] / "data"


@pytest.fixture(scope="session")
def abpo_obs():
    return read_obs(DATA / "abpo0080.15o.gz")


@pytest.fixture(scope="session")
def abpo_nav():
    return read_nav(DATA / "abpo0080.15n.gz")


@pytest.fixture(scope="session")
def abpo_eph(abpo_nav):
    return ephemeris.from_columns(abpo_nav.records)


def code_observations(obs_file, p1=True):
    """Observations from a RINEX file: iono-free P1/P2 (p1=True) or C1 only."""
    nan = np.full(len(obs_file.prn), np.nan)
    return measurements.from_code(
        obs_file.week,
        obs_file.time,
        obs_file.start,
        obs_file.prn,
        observable(obs_file, "P1") if p1 else nan,
        observable(obs_file, "P2") if p1 else nan,
        observable(obs_file, "C1"),
        snr=observable(obs_file, "S1"),
    )


@pytest.fixture(scope="session")
def abpo_epochs(abpo_obs, abpo_eph):
    return measurements.attach_satellites(code_observations(abpo_obs), abpo_eph)


@pytest.fixture(scope="session")
def abpo_spp(abpo_epochs):
    return spp.solve(abpo_epochs)


@pytest.fixture(scope="session")
def tc_flight():
    return read_psins_tc(DATA / "insgpseo_tc.mat")


@pytest.fixture(scope="session")
def tc_epochs(tc_flight):
    obs = measurements.from_record(tc_flight.gnss)
    return measurements.attach_satellites(obs, ephemeris.from_columns(tc_flight.ephemeris))


@pytest.fixture(scope="session")
def tc_spp(tc_epochs):
    return spp.solve(tc_epochs)
