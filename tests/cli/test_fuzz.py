"""Property-based test (issue 8): mutated shipped scenarios and table-data files never
crash a run.

Every run must end with exit 0, 1 or 2 (never 3, a signal or a hang) and leave no
partial file in its output folder. Scenarios are mutated at a random key (a value of
another type, out of range, NaN/infinity, a key removed, a key added); table-data
files at a random dataset (NaN, a column dropped, another dtype, rows cut, removed) or
as bytes (truncated). Runs are in-process through the CLI's exception-to-exit-code
mapping (:func:`inins.cli._runner.guarded`) at 2 Hz with a stated limit of 40,000
samples, so each takes well under a second.

``make test`` runs :data:`EXAMPLES` (150) examples of each test, 300 in all,
derandomized (the same every run);
``make fuzz`` sets ``ININS_FUZZ_EXAMPLES`` for more, with a random seed.
"""

import copy
import functools
import math
import os
from pathlib import Path

import h5py
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from inins.cli._runner import guarded
from inins.commands import budget, find_command
from inins.commands.execute import execute

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = int(os.environ.get("ININS_FUZZ_EXAMPLES", "150"))
"""Examples of each of the two property tests (300 in all; ``make fuzz``: 5000 each)."""
RANDOM = "ININS_FUZZ_EXAMPLES" in os.environ
FAST = {"imu.sample_rate_hz": 2, "output.truth_rate_hz": 2}
SCENARIOS = [
    ("simulate-table", "simulate-table/default.yaml", ""),
    ("simulate-table", "simulate-table/ett-positions.yaml", ""),
    ("calibrate-bias", "calibrate-bias/default.yaml", "simulate"),
    ("align-ett", "align-ett/default.yaml", "simulate"),
    ("import-log", "import-log/csv-example.yaml", None),
    ("import-log", "import-log/default.yaml", None),
]
FUZZ_SETTINGS = settings(
    max_examples=EXAMPLES,
    deadline=None,
    derandomize=not RANDOM,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)


def _set(data, path, value):
    node = data
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value


@functools.cache
def _base(relative, section):
    """A shipped scenario as data, made fast, with file paths made absolute (parsed once;
    callers mutate a deep copy)."""
    path = ROOT / "configs" / relative
    data = yaml.safe_load(path.read_text())
    if section is not None:
        for dotted, value in FAST.items():
            keys = ([section] if section else []) + dotted.split(".")
            node = data
            for key in keys[:-1]:
                node = node.setdefault(key, {})
            node[keys[-1]] = value
    if "log" in data:
        data["log"]["file"] = str((path.parent / data["log"]["file"]).resolve())
    return data


def _leaves(data, prefix=()):
    """Every key path of a nested dict/list (inner nodes too)."""
    out = []
    items = data.items() if isinstance(data, dict) else enumerate(data)
    for key, value in items:
        out.append((*prefix, key))
        if isinstance(value, dict | list) and value:
            out.extend(_leaves(value, (*prefix, key)))
    return out


VALUES = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.sampled_from([0, -1, 1, 1e-300, -1e-9, 1e300, 1e12, math.nan, math.inf, -math.inf]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8),
    st.sampled_from(["", "abc", "1e400", "nan", "hold", "yaw", "../x", "-z", "+q", "none.h5"]),
    st.lists(st.floats(allow_nan=True, allow_infinity=True, width=32), max_size=4),
    st.lists(st.integers(-3, 3), max_size=4),
    st.dictionaries(st.sampled_from(["kind", "x", "duration_s", "axis"]), st.integers(-2, 5)),
)


@st.composite
def mutated_scenario(draw):
    index = draw(st.integers(0, len(SCENARIOS) - 1))
    command, relative, section = SCENARIOS[index]
    data = copy.deepcopy(_base(relative, section))
    paths = _leaves(data)
    for _ in range(draw(st.integers(1, 2))):
        path = draw(st.sampled_from(paths))
        try:
            action = draw(st.sampled_from(["value", "value", "delete", "extra"]))
            node = data
            for key in path[:-1]:
                node = node[key]
            if action == "delete":
                del node[path[-1]]
                paths = _leaves(data)
            elif action == "extra" and isinstance(node, dict):
                node[draw(st.sampled_from(["extra_key", "seed", "checks", "x_s"]))] = draw(VALUES)
            else:
                node[path[-1]] = draw(VALUES)
        except (KeyError, IndexError, TypeError):
            continue
    return command, data


def _exit_code(command, scenario, outdir):
    def body():
        done = execute(find_command(command), scenario, (), None, outdir)
        return 0 if done.summary["passed"] else 1

    return guarded(f"inins {command}", False, body)


def _assert_clean(outdir, code, capsys):
    err = capsys.readouterr().err
    assert code in (0, 1, 2), err
    if outdir.exists():
        left = [p.name for p in outdir.iterdir() if ".partial-" in p.name or "probe" in p.name]
        assert left == [], left


@pytest.fixture
def limited(monkeypatch):
    monkeypatch.setattr(budget, "MAX_SAMPLES", 40_000)


@FUZZ_SETTINGS
@given(case=mutated_scenario())
def test_mutated_scenarios_never_crash(case, tmp_path_factory, limited, capsys):
    command, data = case
    folder = tmp_path_factory.mktemp("fuzz")
    scenario = folder / "s.yaml"
    scenario.write_text(yaml.safe_dump(data, allow_unicode=True))
    outdir = folder / "out"
    _assert_clean(outdir, _exit_code(command, scenario, outdir), capsys)


# -- table-data files ---------------------------------------------------------------
@pytest.fixture(scope="module")
def table_files(tmp_path_factory):
    """Small float64 table-data files: the 000 sequence and the ETT positions, 2 Hz."""
    out = tmp_path_factory.mktemp("tables")
    files = {}
    for name, relative in (("seq", "default.yaml"), ("ett", "ett-positions.yaml")):
        items = [f"{k}={v}" for k, v in FAST.items()]
        items += ["imu.gyro.pulse_weight_arcsec=0", "imu.accel.pulse_weight_ug_s=0"]
        scenario = ROOT / "configs" / "simulate-table" / relative
        execute(find_command("simulate-table"), scenario, items, outdir=out / name)
        files[name] = out / name / "simulate-table.h5"
    return files


DATASETS = [
    "imu/dtheta",
    "imu/dv",
    "table/time",
    "table/encoder",
    "steps/start_index",
    "steps/stop_index",
    "steps/start_time",
    "steps/kind",
    "steps/axis",
    "steps/angles_end",
    "truth/quat_nb",
]


def _edit_file(path, key, how, row, raw_cut):
    if how == "cut-bytes":
        data = path.read_bytes()
        path.write_bytes(data[: int(len(data) * raw_cut)])
        return
    with h5py.File(path, "r+") as f:
        if how == "attr":
            group = f[key.split("/")[0]]
            name = sorted(group.attrs)[row % len(group.attrs)] if len(group.attrs) else None
            if name is not None:
                group.attrs[name] = [math.nan, "x", -1.0][row % 3]
            return
        old = f[key][()]
        attrs = dict(f[key].attrs)
        if how == "nan" and old.dtype.kind == "f" and old.size:
            old = old.copy()
            old.reshape(-1)[row % old.size] = [math.nan, math.inf, 1e308][row % 3]
            new = old
        elif how == "drop-column" and old.ndim == 2:
            new = old[:, :-1]
        elif how == "dtype":
            try:
                new = old.astype(["int8", "float32", "S4"][row % 3])
            except (ValueError, TypeError):
                new = old.astype("S4")
        elif how == "cut-rows":
            new = old[: row % max(1, len(old))]
        elif how == "delete":
            del f[key]
            return
        else:
            new = old[::-1].copy()
        del f[key]
        f[key] = new
        for name, value in attrs.items():
            f[key].attrs[name] = value


@FUZZ_SETTINGS
@given(
    which=st.sampled_from([("seq", "calibrate-bias"), ("ett", "align-ett")]),
    key=st.sampled_from(DATASETS),
    how=st.sampled_from(["nan", "drop-column", "dtype", "cut-rows", "delete", "reverse", "attr"]),
    row=st.integers(0, 10**6),
    raw_cut=st.floats(0.0, 0.99),
    cut_bytes=st.booleans(),
)
def test_mutated_table_data_never_crashes(
    table_files, tmp_path_factory, limited, capsys, which, key, how, row, raw_cut, cut_bytes
):
    name, command = which
    folder = tmp_path_factory.mktemp("fuzzdata")
    path = folder / "t.h5"
    path.write_bytes(table_files[name].read_bytes())
    _edit_file(path, key, "cut-bytes" if cut_bytes and row % 4 == 0 else how, row, raw_cut)
    text = f"data: t.h5\n{'alignment: {method: gyrocompass}' if name == 'seq' else ''}\n"
    if name == "ett":
        text += "positions: {vertical_label: vertical, level_label: level}\n"
    (folder / "s.yaml").write_text(text)
    outdir = folder / "out"
    _assert_clean(outdir, _exit_code(command, folder / "s.yaml", outdir), capsys)


def test_the_table_files_are_valid(table_files, tmp_path):
    # The unmutated files run (so the mutations above start from a working input).
    for name, command in (("seq", "calibrate-bias"), ("ett", "align-ett")):
        folder = tmp_path / name
        folder.mkdir()
        (folder / "t.h5").write_bytes(table_files[name].read_bytes())
        text = "data: t.h5\n"
        if name == "ett":
            text += "positions: {vertical_label: vertical, level_label: level}\n"
        (folder / "s.yaml").write_text(text)
        assert _exit_code(command, folder / "s.yaml", folder / "out") == 0  # no checks given
        made = {p.name for p in (folder / "out").iterdir()}
        assert {f"{command}.h5", f"{command}.txt", "summary.json"} <= made, made
        assert not [n for n in made if ".partial-" in n]
