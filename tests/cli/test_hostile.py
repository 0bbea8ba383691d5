"""The newer commands held to the contract (issue 18): one regression test per class of
hostile input, on every command that reads that input.

Corrupt recorded data is checked once at the edge (:mod:`inins.io.flight_checks`), so
import-flight and run-ekf refuse the same PSINS file with the same message; absurd runs
are refused before they start (:mod:`inins.commands.preflight`) with the key, the
estimate and the limit; numerical edges are refused with the reason. Runs go
in-process through :func:`inins.cli._runner.run_command` (the CLI's mapping of
exceptions to exit codes).
"""

import copy
import json
from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.io
import yaml

from inins.cli._runner import run_command
from inins.commands import find_command
from inins.io.flight_layout import read_flight, write_flight
from inins.io.psins_tc import read_psins_tc

ROOT = Path(__file__).resolve().parents[2]
CONFIGS = ROOT / "configs"
MAT = ROOT / "data" / "insgpseo_tc.mat"
OBS = ROOT / "data" / "abpo0080.15o.gz"
NAV = ROOT / "data" / "abpo0080.15n.gz"
SHORT_FLIGHT = [
    {"kind": "wait", "duration_s": 10},
    {"kind": "takeoff", "duration_s": 40, "speed_mps": 80},
    {"kind": "turn", "bank_deg": 30, "angle_deg": 90},
]

FAST = {"flight.imu.sample_rate_hz": 50, "flight.dither.amplitude_arcsec": 0}


def run(command, scenario=None, *items, outdir=None, force=False):
    """Exit code of ``inins COMMAND [SCENARIO] --set ITEM ...`` in-process."""
    return run_command(find_command(command), scenario, outdir, list(items), None, force=force)


def _no_partials(folder):
    if Path(folder).exists():
        left = [p.name for p in Path(folder).rglob("*") if ".partial-" in p.name]
        assert left == [], left


def _ekf_scenario(tmp_path, **changes):
    data = yaml.safe_load((CONFIGS / "run-ekf" / "default.yaml").read_text())
    data["flight"]["legs"] = copy.deepcopy(SHORT_FLIGHT)
    data["filter"]["turning_from_s"] = 50
    data["checks"] = []
    for dotted, value in changes.items():
        node = data
        *path, last = dotted.split(".")
        for key in path:
            node = node[int(key)] if isinstance(node, list) else node[key]
        node[int(last) if isinstance(node, list) else last] = value
    path = tmp_path / "ekf.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


# -- 1. absurd runs refused up front ------------------------------------------------
@pytest.mark.parametrize(
    ("changes", "key", "limit"),
    [
        ({"flight.legs.2.duration_s": 3.2e8}, "flight.legs", "2e+07 samples"),  # 10 years
        ({"flight.imu.sample_rate_hz": 1e6}, "flight.imu.sample_rate_hz", "2e+07 samples"),
        ({"flight.legs.2.angle_deg": 1e9}, "flight.legs", "2e+07 samples"),
    ],
)
def test_absurd_run_ekf_is_refused_with_key_estimate_and_limit(
    changes, key, limit, tmp_path, capsys
):
    out = tmp_path / "out"
    assert run("run-ekf", _ekf_scenario(tmp_path, **changes), outdir=out) == 2
    err = capsys.readouterr().err
    assert key in err and "this run would need" in err and limit in err and "--force" in err
    assert not out.exists() or list(out.iterdir()) == []


def _obs_scenario(tmp_path, **data):
    base = yaml.safe_load((CONFIGS / "observability" / "default.yaml").read_text())
    base.update(data)
    path = tmp_path / "obs.yaml"
    path.write_text(yaml.safe_dump(base))
    return path


def test_absurd_observability_is_refused(tmp_path, capsys, monkeypatch):
    from inins.commands import preflight

    monkeypatch.setattr(preflight, "OBS_MAX_SEGMENTS", 10)  # the stated 20,000, made small
    flight = {"scenario": str(CONFIGS / "paper003" / "ekf2-fb.yaml"), "sample_rate_hz": 1e6}
    path = _obs_scenario(tmp_path, segments=[], flight=flight)
    assert run("observability", path, outdir=tmp_path / "a") == 2
    assert "flight.sample_rate_hz" in capsys.readouterr().err
    long = [{"duration_s": 1e9, "heading_deg": 0, "speed_mps": 100}]
    assert run("observability", _obs_scenario(tmp_path, segments=long), outdir=tmp_path / "b") == 2
    err = capsys.readouterr().err
    assert "covariance steps" in err and "limit of 2e+07" in err
    many = [{"duration_s": 1, "heading_deg": k % 360, "speed_mps": 100} for k in range(11)]
    assert run("observability", _obs_scenario(tmp_path, segments=many), outdir=tmp_path / "c") == 2
    assert "11 segments" in capsys.readouterr().err


def test_force_runs_past_the_limit(tmp_path, monkeypatch):
    from inins.commands import preflight

    monkeypatch.setattr(preflight, "EKF_MAX_SAMPLES", 1000)
    path = _ekf_scenario(tmp_path, **FAST)
    assert run("run-ekf", path, outdir=tmp_path / "a") == 2
    assert run("run-ekf", path, outdir=tmp_path / "b", force=True) == 0


def test_sweep_counts_points_before_expanding(tmp_path, capsys):
    from inins.sweep.plan import load_sweep

    sweep = tmp_path / "s.yaml"
    sweep.write_text(
        "command: calibrate-bias\ngrid:\n"
        "  simulate.imu.sample_rate_hz: {start: 1, stop: 1.0e9, step: 1.0e-9}\n"
    )
    with pytest.raises(Exception, match="more than --max-points"):
        load_sweep(sweep)
    absurd = tmp_path / "p.yaml"
    absurd.write_text(
        f"command: run-ekf\nbase: {CONFIGS / 'run-ekf' / 'default.yaml'}\n"
        "grid:\n  flight.imu.sample_rate_hz: [200, 1.0e6]\n"
    )
    with pytest.raises(Exception, match=r"grid\.flight\.imu\.sample_rate_hz.*limit"):
        load_sweep(absurd)


# -- 2. corrupt recorded data: the PSINS file, read by import-flight and run-ekf ------
@pytest.fixture(scope="module")
def mat():
    return scipy.io.loadmat(MAT)


def _mat_case(mat, folder, edit):
    arrays = {k: v.copy() for k, v in mat.items() if not k.startswith("__")}
    edit(arrays)
    path = folder / "bad.mat"
    scipy.io.savemat(path, arrays)
    return path


def _swap_rows(a, i, j):
    a[[i, j]] = a[[j, i]]


def _swap_epochs(a):
    t = a["obss"][:, 0]
    first = np.flatnonzero(t == t[0])
    second = np.flatnonzero(t == t[first[-1] + 1])
    a["obss"][first, 0], a["obss"][second, 0] = t[second[0]], t[first[0]]


MAT_CASES = {
    "nan-dtheta": (lambda a: a["imu"].__setitem__((1000, 1), np.nan), "imu/dtheta: row 1000: NaN"),
    "inf-dv": (lambda a: a["imu"].__setitem__((5, 4), np.inf), "imu/dv: row 5: infinity"),
    "nan-time": (lambda a: a["imu"].__setitem__((7, 6), np.nan), "imu/time: row 7: NaN"),
    "backwards": (lambda a: _swap_rows(a["imu"], 300, 301), "imu/time: row 301"),
    "time-ms": (lambda a: a["imu"].__setitem__((slice(None), 6), a["imu"][:, 6] * 1e3), "ms"),
    "empty-imu": (lambda a: a.__setitem__("imu", np.zeros((0, 7))), "0 samples (empty?)"),
    "transposed": (lambda a: a.__setitem__("imu", a["imu"].T.copy()), "transposed"),
    "rates": (lambda a: a["imu"].__setitem__((20, 0), 5.0), "beyond any IMU"),
    "prn-40": (lambda a: a["obss"].__setitem__((3, 1), 40), "not a GPS PRN"),
    "swapped": (_swap_epochs, "epochs out of order"),
    "text": (lambda a: a.__setitem__("t0", np.array(["abc"])), "'t0'"),
    "no-ephs": (lambda a: a.pop("ephs"), "'ephs' missing"),
    "no-overlap": (lambda a: a.__setitem__("t0", a["t0"] + 9e4), "no GNSS epoch during the IMU"),
}


@pytest.mark.parametrize("case", sorted(MAT_CASES))
@pytest.mark.parametrize("command", ["import-flight", "run-ekf"])
def test_corrupt_psins_file_is_bad_input_in_both_commands(mat, case, command, tmp_path, capsys):
    edit, expected = MAT_CASES[case]
    path = _mat_case(mat, tmp_path, edit)
    if command == "import-flight":
        items = [f"file={path}"]
        scenario = CONFIGS / "import-flight" / "psins-tc.yaml"
    else:
        items = [f"data.file={path}"]
        scenario = CONFIGS / "run-ekf" / "psins-tc.yaml"
    out = tmp_path / "out"
    assert run(command, scenario, *items, outdir=out) == 2
    err = capsys.readouterr().err
    assert expected in err and str(path) in err, err
    _no_partials(out)


def test_nan_pseudoranges_are_dropped_counted_and_reported(mat, tmp_path):
    def edit(a):
        a["obss"][[10, 11, 12], 2] = np.nan

    path = _mat_case(mat, tmp_path, edit)
    flight = read_psins_tc(path)
    assert flight.dropped == (
        "gnss/obs/pseudorange: 3 measurements with a non-finite or non-positive "
        "pseudorange dropped (first row 10)",
    )
    out = tmp_path / "out"
    items = [f"file={path}", "checks=[]"]
    assert (
        run("import-flight", CONFIGS / "import-flight" / "psins-tc.yaml", *items, outdir=out) == 0
    )
    report = (out / "import-flight.txt").read_text()
    assert "3 measurements with a non-finite" in report
    # what import-flight wrote, run-ekf reads with the same counts (nothing more dropped)
    assert read_flight(out / "import-flight.h5").dropped == ()
    assert len(read_flight(out / "import-flight.h5").gnss.prn) == len(flight.gnss.prn)


# -- 2. corrupt recorded data: the recorded-flight layout (run-ekf) -------------------
@pytest.fixture(scope="module")
def layout_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("layout") / "flight.h5"
    write_flight(path, read_psins_tc(MAT))
    return path


def _edit_layout(src, dst, edit):
    dst.write_bytes(src.read_bytes())
    with h5py.File(dst, "r+") as f:
        edit(f)
    return dst


def _replace(key, value):
    def edit(f):
        del f[key]
        f[key] = value

    return edit


def _mutate(key, func):
    def edit(f):
        value = f[key][()]
        del f[key]
        f[key] = func(value)

    return edit


def _set(array, index, value):
    array = array.copy()
    array[index] = value
    return array


LAYOUT_CASES = {
    "version": (lambda f: f.attrs.__setitem__("layout_version", 7), "layout_version 7"),
    "missing": (lambda f: f.__delitem__("gnss/obs/prn"), "gnss/obs/prn: dataset missing"),
    "imu-part": (lambda f: f.__delitem__("imu/dv"), "imu/dv: dataset missing"),
    "start-range": (
        _mutate("gnss/epoch/start", lambda v: _set(v, 5, 10**9)),
        "gnss/epoch/start: row 5",
    ),
    "dv-shape": (_mutate("imu/dv", lambda v: v[:, :2]), "imu/dv: has shape"),
    "string": (_replace("gnss/obs/pseudorange", np.array([b"x"] * 4)), "expected float64"),
    "duplicated": (
        _mutate("gnss/epoch/time", lambda v: _set(v, 9, v[8])),
        "gnss/epoch/time: row 9",
    ),
    "prn": (_mutate("gnss/obs/prn", lambda v: _set(v, 0, 0)), "gnss/obs/prn: row 0"),
    "nan-dtheta": (
        _mutate("imu/dtheta", lambda v: _set(v, (1000, 2), np.nan)),
        "imu/dtheta: row 1000: NaN",
    ),
    "week": (_mutate("gnss/epoch/week", lambda v: _set(v, 0, -5)), "gnss/epoch/week: row 0"),
}


@pytest.mark.parametrize("case", sorted(LAYOUT_CASES))
def test_corrupt_layout_file_is_bad_input(layout_file, case, tmp_path, capsys):
    edit, expected = LAYOUT_CASES[case]
    path = _edit_layout(layout_file, tmp_path / "bad.h5", edit)
    out = tmp_path / "out"
    assert (
        run("run-ekf", CONFIGS / "run-ekf" / "psins-tc.yaml", f"data.file={path}", outdir=out) == 2
    )
    err = capsys.readouterr().err
    assert expected in err, err
    _no_partials(out)


def test_zero_forward_axis_is_refused(tmp_path, capsys):
    items = ["data.forward_axis_b=[0, 0, 0]"]
    assert run("run-ekf", CONFIGS / "run-ekf" / "psins-tc.yaml", *items, outdir=tmp_path) == 2
    assert "data.forward_axis_b" in capsys.readouterr().err


# -- 2. corrupt RINEX (import-flight) -------------------------------------------------
@pytest.fixture(scope="module")
def rinex_lines():
    import gzip

    lines = gzip.open(OBS, "rt").read().splitlines(True)
    return lines, next(i for i, line in enumerate(lines) if "END OF HEADER" in line)


def _rinex(lines, header, edit, folder, keep=3000):
    body = lines[: header + 1 + keep]
    del body[_first_epochs(body, header)[-1] :]  # whole epochs only
    edit(body, header)
    path = folder / "bad.15o"
    path.write_text("".join(body))
    return path


def _count(body, header, delta):
    line = body[header + 1]
    body[header + 1] = line[:29] + f"{int(line[29:32]) + delta:3d}" + line[32:]


def _first_epochs(body, header):
    """Line numbers (0-based) of the epoch lines."""
    import re

    return [i for i in range(header + 1, len(body)) if re.match(r"^ \d\d [ \d]\d [ \d]\d", body[i])]


def _duplicate(body, header):
    epochs = _first_epochs(body, header)
    body[epochs[1]] = body[epochs[0]][:26] + body[epochs[1]][26:]


def _swap(body, header):
    epochs = _first_epochs(body, header)
    first, second = body[epochs[0]], body[epochs[1]]
    body[epochs[0]] = second[:26] + first[26:]
    body[epochs[1]] = first[:26] + second[26:]


def _drop_record(body, header):
    del body[header + 2 : header + 4]  # one satellite's two lines


RINEX_CASES = {
    "count-more": (lambda b, h: _count(b, h, 1), "counts 9 satellites but lists 8"),
    "count-less": (lambda b, h: _count(b, h, -1), "counts 7 satellites but lists 8"),
    "records-short": (_drop_record, "only 7 records follow"),
    "header-only": (lambda b, h: b.__delitem__(slice(h + 1, None)), "header-only"),
    "duplicated": (_duplicate, "repeats the epoch"),
    "swapped": (_swap, "comes before the epoch"),
}


@pytest.mark.parametrize("case", sorted(RINEX_CASES))
def test_corrupt_rinex_is_bad_input_at_its_line(rinex_lines, case, tmp_path, capsys):
    edit, expected = RINEX_CASES[case]
    path = _rinex(*rinex_lines, edit, tmp_path)
    items = [f"obs_file={path}", f"nav_file={NAV}", "checks=[]"]
    out = tmp_path / "out"
    assert run("import-flight", CONFIGS / "import-flight" / "default.yaml", *items, outdir=out) == 2
    err = capsys.readouterr().err
    assert expected in err and f"{path}:" in err, err
    _no_partials(out)


# -- 3. numerical edges ---------------------------------------------------------------
@pytest.mark.parametrize(
    ("changes", "expected"),
    [
        ({"flight.site.lat_deg": 90.0}, "flight.site.lat_deg: 90 deg is within 0.5 deg of a pole"),
        ({"flight.site.lat_deg": -89.9999}, "of a pole"),
        ({"flight.legs.2.bank_deg": 89.9}, "flight.legs[2].bank_deg: bank 89.9 deg"),
        ({"flight.dither.frequency_hz": 150.0}, "above the Nyquist frequency 100 Hz"),
        ({"filter.turning_from_s": 1e6}, "filter.turning_from_s: 1e+06 s is at or after the end"),
    ],
)
def test_numerical_edges_are_refused_with_the_reason(changes, expected, tmp_path, capsys):
    assert run("run-ekf", _ekf_scenario(tmp_path, **changes), outdir=tmp_path / "out") == 2
    assert expected in capsys.readouterr().err


@pytest.mark.parametrize(
    "command", ["run-ekf", "observability", "import-flight", "calibrate-bias", "simulate-table"]
)
def test_deeply_nested_yaml_is_refused_by_the_loader(command, tmp_path, capsys):
    path = tmp_path / "deep.yaml"
    path.write_text("a: " + "[" * 400 + "]" * 400 + "\n")
    assert run(command, path, outdir=tmp_path / "out") == 2
    assert "nested more than 64 levels deep" in capsys.readouterr().err
    assert run(command, None, "seed=" + "{a: " * 300 + "1" + "}" * 300, outdir=tmp_path) == 2
    assert "nested more than" in capsys.readouterr().err


# -- 5. output folders ----------------------------------------------------------------
def test_another_commands_folder_is_refused(tmp_path, capsys):
    (tmp_path / "summary.json").write_text(json.dumps({"command": "calibrate-bias"}))
    (tmp_path / "calibrate-bias.h5").write_bytes(b"")
    path = _ekf_scenario(tmp_path / "..", **{})
    assert run("run-ekf", path, outdir=tmp_path) == 2
    err = capsys.readouterr().err
    assert "holds the results of inins calibrate-bias" in err and "run-ekf" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["calibrate-bias.h5", "summary.json"]


def test_empty_and_default_output_folder(tmp_path, monkeypatch):
    from typer.testing import CliRunner

    from inins.cli import app

    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(app, ["import-flight", "-o", ""])
    assert result.exit_code == 2 and "empty output folder" in result.output
    scenario = CONFIGS / "import-flight" / "psins-tc.yaml"
    result = CliRunner().invoke(app, ["import-flight", str(scenario)])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "out" / "import-flight" / "summary.json").exists()


# -- 7. figures and reports -----------------------------------------------------------
def test_ff_run_skips_the_all_zero_figure_and_says_why(tmp_path):
    pytest.importorskip("matplotlib")
    path = _ekf_scenario(tmp_path, **FAST, **{"filter.coupling": "ff"})
    out = tmp_path / "out"
    (out).mkdir()
    (out / "run-ekf-fb-corrections.png").write_bytes(b"stale")  # an earlier FB run's
    code = run_command(find_command("run-ekf"), path, out, [], None, plot=True)
    assert code == 0
    assert not (out / "run-ekf-fb-corrections.png").exists()
    assert (out / "run-ekf-heading-error.png").stat().st_size > 10_000
    report = (out / "run-ekf.txt").read_text()
    assert "run-ekf-fb-corrections.png not drawn" in report and "ff coupling" in report
    assert "deg/h" in report and "arcsec" in report and "(est-truth)/sigma" in report
    assert "nan" not in report


def test_recording_report_says_n_a_not_nan(tmp_path):
    out = tmp_path / "out"
    assert run("run-ekf", CONFIGS / "run-ekf" / "psins-tc.yaml", outdir=out) == 0
    report = (out / "run-ekf.txt").read_text()
    assert "NEES mean n/a (recording without truth)" in report
    assert "truth: n/a (recording without truth)" in report
    assert "nan" not in report.lower().replace("nanosecond", "")


# -- 8. one vocabulary ----------------------------------------------------------------
def test_schema_sweep_and_wrapping(monkeypatch):
    from typer.testing import CliRunner

    from inins.cli import app

    result = CliRunner().invoke(app, ["schema", "sweep"])
    assert result.exit_code == 0 and "grid" in result.output and "seeds" in result.output
    monkeypatch.setenv("COLUMNS", "80")
    result = CliRunner().invoke(app, ["schema", "run-ekf"])
    assert result.exit_code == 0
    assert max(map(len, result.output.splitlines())) <= 80
