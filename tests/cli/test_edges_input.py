"""Bad input at the edges (issue 8, items 5-8): absurd sizes refused up front, bad
table-data files as bad input, messages that name the place, checks validated before
the run. Runs go in-process through :func:`inins.cli._runner.run_command`.
"""

import json
import os
import subprocess
from pathlib import Path

import h5py
import numpy as np
import pytest

from inins.cli._runner import run_command
from inins.commands import COMMANDS, find_command, load_command
from inins.commands import budget as budget_module
from inins.commands.execute import execute, load
from inins.io import diskspace

ROOT = Path(__file__).resolve().parents[2]
REFERENCE = ROOT / "tests" / "data" / "reference_summaries.json"


def run(command, *args, outdir=None, seed=None, force=False, scenario=None):
    """Exit code of ``inins COMMAND`` in-process (``args``: --set items)."""
    return run_command(find_command(command), scenario, outdir, list(args), seed, force=force)


# -- 5. absurd sizes ----------------------------------------------------------------
@pytest.mark.parametrize(
    ("command", "item"),
    [
        ("simulate-table", "imu.sample_rate_hz=1e12"),
        ("simulate-table", "motion.1.duration_s=3.15e8"),
        ("calibrate-bias", "simulate.imu.sample_rate_hz=1e9"),
        ("align-ett", "simulate.motion.0.duration_s=1e9"),
    ],
)
def test_absurd_sizes_are_refused_with_the_estimate(command, item, tmp_path, capsys, monkeypatch):
    spec = load_command(find_command(command))
    monkeypatch.setattr(spec, "run", lambda *a, **k: pytest.fail("the run started"))
    assert run(command, item, outdir=tmp_path) == 2
    err = capsys.readouterr().err
    assert "samples" in err and "pass --force" in err and "1e+09 samples" in err
    assert list(tmp_path.iterdir()) == []


def test_memory_and_disk_limits(monkeypatch, tmp_path):
    _, loaded = load(find_command("calibrate-bias"))
    estimate = load_command(find_command("calibrate-bias")).estimate(loaded.model)
    # the default: 1597 s at 200 Hz, in memory: 3 x (48 B/sample + truth rows)
    assert estimate.samples == 319_400
    assert 3 * 48 * 319_400 < estimate.memory_bytes < 4 * 48 * 319_400
    monkeypatch.setattr(diskspace, "available_memory", lambda: estimate.memory_bytes - 1)
    with pytest.raises(Exception, match="more memory than the"):
        budget_module.check_budget(estimate)
    budget_module.check_budget(estimate, force=True)  # --force: the deliberate case
    monkeypatch.setattr(diskspace, "available_memory", lambda: None)
    monkeypatch.setattr(diskspace, "free_bytes", lambda path: estimate.output_bytes - 1)
    with pytest.raises(Exception, match="free on") as exc:
        budget_module.check_budget(estimate, tmp_path)
    assert type(exc.value).__name__ == "OutputError"


def test_a_motion_shorter_than_one_truth_interval_is_bad_input(tmp_path, capsys):
    items = ("imu.sample_rate_hz=1e-4", "output.truth_rate_hz=1e-4")  # 1597 s: 0 samples
    assert run("simulate-table", *items, outdir=tmp_path) == 2
    assert "shorter than one truth interval" in capsys.readouterr().err


# -- 6. bad data as bad input -------------------------------------------------------
@pytest.fixture(scope="module")
def table_file(tmp_path_factory):
    """A float64 table-data file: the ETT positions, increments not quantized."""
    out = tmp_path_factory.mktemp("table")
    execute(
        find_command("simulate-table"),
        ROOT / "configs" / "simulate-table" / "ett-positions.yaml",
        ["imu.gyro.pulse_weight_arcsec=0", "imu.accel.pulse_weight_ug_s=0"],
        outdir=out,
    )
    return out / "simulate-table.h5"


def _mutated(table_file, tmp_path, edit):
    path = tmp_path / "t.h5"
    path.write_bytes(table_file.read_bytes())
    with h5py.File(path, "r+") as f:
        edit(f)
    (tmp_path / "s.yaml").write_text("data: t.h5\n")
    return tmp_path / "s.yaml"


def _nan_row(key, row=1000):
    def edit(f):
        f[key][row, 1] = np.nan

    return edit


def _replace(key, data):
    def edit(f):
        attrs = dict(f[key].attrs)
        new = data(f) if callable(data) else data
        del f[key]
        f[key] = new
        f[key].attrs.update(attrs)

    return edit


@pytest.mark.parametrize(
    ("edit", "where"),
    [
        (_nan_row("imu/dtheta"), "imu/dtheta: row 1000 is not finite"),
        (_nan_row("imu/dv"), "imu/dv: row 1000 is not finite"),
        (_replace("imu/dtheta", np.zeros((10, 2))), "imu/dtheta: expected shape (nx3)"),
        (_replace("imu/dv", np.zeros((10, 3))), "imu: imu/dtheta and imu/dv differ"),
        (_replace("table/time", lambda f: f["table/time"][()][::-1]), "table/time: times must not"),
        (_replace("imu/dv", np.array(["a", "b"], dtype="S1")), "imu/dv: expected a numeric"),
        (lambda f: f["imu"].attrs.__setitem__("dt_s", -1.0), "imu: attribute dt_s must be"),
        (lambda f: f["steps/stop_index"].__setitem__(0, 10**9), "steps/start_index: step"),
    ],
)
@pytest.mark.parametrize("command", ["calibrate-bias", "align-ett"])
def test_bad_table_data_is_bad_input(table_file, tmp_path, capsys, edit, where, command):
    scenario = _mutated(table_file, tmp_path, edit)
    assert run(command, scenario=scenario, outdir=tmp_path / "out") == 2
    err = capsys.readouterr().err
    assert f"{tmp_path / 't.h5'}: {where}" in err, err


def test_seed_too_large(tmp_path, capsys):
    assert run("import-log", outdir=tmp_path, seed=2**64) == 2
    assert "--seed: seed 18446744073709551616 is outside" in capsys.readouterr().err
    assert run("import-log", f"seed={2**64}", outdir=tmp_path) == 2
    assert "seed: must be <= 9223372036854775807" in capsys.readouterr().err


def test_non_utf8_scenario_path(tmp_path, capsys):
    folder = Path(os.fsdecode(bytes(tmp_path) + b"/caf\xe9"))
    folder.mkdir()
    scenario = folder / "s.yaml"
    scenario.write_text((ROOT / "configs" / "import-log" / "default.yaml").read_text())
    assert run("import-log", scenario=scenario, outdir=tmp_path / "out") == 2
    assert "SCENARIO: the path is not valid UTF-8" in capsys.readouterr().err
    assert run("import-log", outdir=folder / "out") == 2
    assert "--outdir: the path is not valid UTF-8" in capsys.readouterr().err


def test_unwritable_output_folder(tmp_path, capsys):
    # As root a mode cannot stop a write: use a read-only tmpfs where one can be mounted.
    target = tmp_path / "ro"
    target.mkdir()
    made = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "ro,size=64k", "tmpfs", str(target)], capture_output=True
    )
    if made.returncode != 0:
        if os.geteuid() == 0:
            pytest.skip("cannot mount a read-only tmpfs")
        target.chmod(0o500)
    try:
        assert run("import-log", outdir=target) == 2
        err = capsys.readouterr().err
        assert f"{target}: cannot write in the output directory" in err, err
    finally:
        if made.returncode == 0:
            subprocess.run(["umount", str(target)], check=False)


# -- 7. messages that name the place ------------------------------------------------
def test_missing_data_file_names_key_and_line(tmp_path, capsys):
    (tmp_path / "s.yaml").write_text("# a comment\n\ndata: none.h5\n")
    assert run("calibrate-bias", scenario=tmp_path / "s.yaml", outdir=tmp_path) == 2
    err = capsys.readouterr().err
    assert f"{tmp_path / 's.yaml'}:3: data: file not found: {tmp_path / 'none.h5'}" in err


def test_data_path_that_is_a_directory(tmp_path, capsys):
    (tmp_path / "d.h5").mkdir()
    (tmp_path / "s.yaml").write_text("data: d.h5\n")
    assert run("align-ett", scenario=tmp_path / "s.yaml", outdir=tmp_path / "o") == 2
    err = capsys.readouterr().err
    assert f"s.yaml:1: data: {tmp_path / 'd.h5'} is a directory, expected a file" in err
    assert "not found" not in err


def test_import_log_step_error_names_file_and_line(tmp_path, capsys):
    text = (ROOT / "configs" / "import-log" / "csv-example.yaml").read_text()
    text = text.replace("../../data/", str(ROOT / "data") + "/")
    text = text.replace("start_s: 1078.0, end_s: 1138.0", "start_s: 5078.0, end_s: 5138.0")
    (tmp_path / "s.yaml").write_text(text)
    line = 1 + text.splitlines().index(next(x for x in text.splitlines() if "start_s: 5078.0" in x))
    assert run("import-log", scenario=tmp_path / "s.yaml", outdir=tmp_path / "o") == 2
    err = capsys.readouterr().err
    assert f"{tmp_path / 's.yaml'}:{line}: steps[2]: step 2 (5078 s to 5138 s)" in err


# -- 8. checks validated before the run ---------------------------------------------
@pytest.mark.parametrize("command", ["calibrate-bias", "align-ett", "simulate-table", "import-log"])
def test_unknown_check_name_is_refused_before_the_run(command, tmp_path, capsys, monkeypatch):
    module = load_command(find_command(command))
    monkeypatch.setattr(module, "run", lambda *a, **k: pytest.fail("the run started"))
    item = 'checks=["abs(beta_q_dph) < 1"]'
    assert run(command, item, outdir=tmp_path) == 2
    err = capsys.readouterr().err
    assert f"checks[0] (from --set {item}): unknown name 'beta_q_dph'" in err
    assert list(tmp_path.iterdir()) == []


def test_unknown_check_name_in_the_file_names_the_line(tmp_path, capsys, monkeypatch):
    module = load_command(find_command("import-log"))
    monkeypatch.setattr(module, "run", lambda *a, **k: pytest.fail("the run started"))
    text = (ROOT / "configs" / "import-log" / "csv-example.yaml").read_text()
    text = text.replace("../../data/", str(ROOT / "data") + "/")
    text = text.replace("abs(implied_lat_err_deg) < 0.2", "abs(earth_rate_q) < 1")
    (tmp_path / "s.yaml").write_text(text)
    line = 1 + next(i for i, x in enumerate(text.splitlines()) if "earth_rate_q" in x)
    assert run("import-log", scenario=tmp_path / "s.yaml", outdir=tmp_path / "o") == 2
    assert f"s.yaml:{line}: checks[1]: unknown name 'earth_rate_q'" in capsys.readouterr().err


def test_declared_names_cover_every_shipped_result():
    # Every result and truth name a shipped scenario gives is declared, so no valid
    # check is refused.
    reference = json.loads(REFERENCE.read_text())
    for source, summary in reference.items():
        spec = find_command(summary["command"])
        module, loaded = load(spec, ROOT / source)
        results, truth = module.declared_results(loaded.model)
        assert set(summary["results"]) <= set(results), source
        assert set(summary["truth"]) <= set(truth), source


def test_every_available_command_declares_names_and_size():
    for spec in COMMANDS:
        if spec.available:
            module = load_command(spec)
            assert callable(module.declared_results) and callable(module.estimate), spec.name
