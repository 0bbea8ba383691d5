"""Property tests of the newer commands (issue 18): arbitrary numbers and arrays fed to
the recorded-flight reader, and arbitrary values at random keys of short run-ekf and
observability scenarios, never crash: exit 0, 1 or 2 only, no partial file.

``make test`` runs :data:`EXAMPLES` examples of each (derandomized); ``make fuzz``
sets ``ININS_FUZZ_EXAMPLES`` for more, with a random seed (as tests/cli/test_fuzz.py).
"""

import copy
import math
import os
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from inins.cli._runner import guarded
from inins.commands import find_command
from inins.commands.execute import execute
from inins.exceptions import InputError
from inins.io.flight_checks import checked_flight
from inins.io.flight_layout import DATASETS, read_flight, write_flight
from inins.io.psins_tc import read_psins_tc
from tests.cli.test_fuzz import VALUES, _leaves

ROOT = Path(__file__).resolve().parents[2]
CONFIGS = ROOT / "configs"
EXAMPLES = max(1, int(os.environ.get("ININS_FUZZ_EXAMPLES", "100")) // 5)
"""Examples of each test: 20 in ``make test`` (the runs take a few tenths of a second)."""
SETTINGS = settings(
    max_examples=EXAMPLES,
    deadline=None,
    derandomize="ININS_FUZZ_EXAMPLES" not in os.environ,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
NUMBERS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -1.0, 1e300, -1e-300, math.nan, math.inf, 2**63, 33.0, 604800.0]),
)


# -- the recorded-flight reader ------------------------------------------------------
@pytest.fixture(scope="module")
def flight_file(tmp_path_factory):
    """The PSINS recording cut to 400 IMU samples and 5 epochs, in the layout."""
    from dataclasses import replace

    flight = read_psins_tc(ROOT / "data" / "insgpseo_tc.mat")
    g = flight.gnss
    t = g.time - flight.imu_t0_sow
    first = int(np.flatnonzero(t > 0)[0])
    rows = slice(g.start[first], g.start[first + 5])
    gnss = replace(
        g,
        week=g.week[first : first + 5],
        time=g.time[first : first + 5],
        start=g.start[first : first + 6] - g.start[first],
        **{k: getattr(g, k)[rows] for k in ("prn", "pseudorange", "signal", "range_rate")},
        **{k: getattr(g, k)[rows] for k in ("sigma", "snr", "carrier")},
    )
    imu = replace(
        flight.imu,
        time=flight.imu.time[:400],
        dtheta=flight.imu.dtheta[:400],
        dv=flight.imu.dv[:400],
    )
    path = tmp_path_factory.mktemp("flight") / "flight.h5"
    write_flight(path, replace(flight, gnss=gnss, imu=imu))
    return path


@st.composite
def dataset_edit(draw):
    key = draw(st.sampled_from([d.path for d in DATASETS] + ["gnss/ephemeris/sqrt_a"]))
    how = draw(st.sampled_from(["value", "value", "array", "delete", "attr"]))
    if how == "array":
        shape = draw(hnp.array_shapes(min_dims=1, max_dims=3, max_side=6))
        dtype = draw(st.sampled_from(["float64", "int64", "int8", "S3"]))
        if dtype == "S3":
            return key, how, np.full(shape, b"abc")
        return key, how, draw(hnp.arrays(dtype, shape))
    return key, how, (draw(st.integers(0, 10_000)), draw(NUMBERS))


def _apply(path, edit):
    key, how, what = edit
    with h5py.File(path, "r+") as f:
        if how == "attr":
            name = ["layout_version", "imu_t0_sow", "imu_t0_week", "reference_pos_e"][what[0] % 4]
            f.attrs[name] = what[1]
            return
        if key not in f:
            return
        if how == "delete":
            del f[key]
            return
        old = f[key][()]
        if how == "value":
            if not old.size:
                return
            new = old.astype(float)
            new.reshape(-1)[what[0] % old.size] = what[1]
        else:
            new = what
        del f[key]
        f[key] = new


@SETTINGS
@given(edits=st.lists(dataset_edit(), min_size=1, max_size=3))
def test_the_flight_reader_takes_any_arrays(edits, flight_file, tmp_path_factory):
    path = tmp_path_factory.mktemp("fz") / "f.h5"
    path.write_bytes(flight_file.read_bytes())
    for edit in edits:
        _apply(path, edit)
    try:
        flight = read_flight(path)
    except InputError:
        return
    again = checked_flight(flight, path)  # what was accepted passes the same rules again
    assert again.dropped == flight.dropped
    assert np.all(np.isfinite(flight.imu.time)) if flight.imu is not None else True
    assert np.all(np.isfinite(flight.gnss.pseudorange))


# -- run-ekf and observability scenarios ----------------------------------------------
def _short_ekf():
    data = yaml.safe_load((CONFIGS / "run-ekf" / "default.yaml").read_text())
    data["flight"]["legs"] = [
        {"kind": "wait", "duration_s": 5},
        {"kind": "takeoff", "duration_s": 20, "speed_mps": 60},
        {"kind": "turn", "bank_deg": 30, "angle_deg": 20},
    ]
    data["flight"]["imu"]["sample_rate_hz"] = 50
    data["flight"]["dither"]["amplitude_arcsec"] = 0
    data["filter"]["turning_from_s"] = 20
    return data


BASES = {
    "run-ekf": _short_ekf(),
    "observability": yaml.safe_load((CONFIGS / "observability" / "default.yaml").read_text()),
}


@st.composite
def mutated(draw):
    command = draw(st.sampled_from(sorted(BASES)))
    data = copy.deepcopy(BASES[command])
    paths = _leaves(data)
    for _ in range(draw(st.integers(1, 2))):
        path = draw(st.sampled_from(paths))
        node = data
        try:
            for key in path[:-1]:
                node = node[key]
            node[path[-1]] = draw(st.one_of(NUMBERS, VALUES))
        except (KeyError, IndexError, TypeError):
            continue
    return command, data


@SETTINGS
@given(case=mutated())
def test_run_ekf_and_observability_scenarios_never_crash(case, tmp_path_factory, capsys):
    command, data = case
    folder = tmp_path_factory.mktemp("fz")
    scenario = folder / "s.yaml"
    scenario.write_text(yaml.safe_dump(data, allow_unicode=True))
    outdir = folder / "out"

    def body():
        done = execute(find_command(command), scenario, (), None, outdir)
        return 0 if done.summary["passed"] else 1

    code = guarded(f"inins {command}", False, body)
    err = capsys.readouterr().err
    assert code in (0, 1, 2), err
    if outdir.exists():
        assert [p.name for p in outdir.iterdir() if ".partial-" in p.name] == []
