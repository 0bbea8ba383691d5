"""Running sweeps locally: the table, resume after an interrupt, points that raise."""

import json

import numpy as np
import pytest

from inins.exceptions import InputError
from inins.io.sweep_files import JOURNAL, read_journal, read_table_h5
from inins.sweep.engine import run_sweep
from inins.sweep.plan import load_sweep


def _run(path, outdir, executor, **kw):
    plan = load_sweep(path)
    return plan, run_sweep(plan, outdir, executor, **kw)


def test_grid_table_holds_every_point_with_its_results(sim_sweep, tmp_path, pool):
    _, outcome = _run(sim_sweep(), tmp_path / "out", pool)
    assert (outcome.planned, outcome.ran, outcome.skipped, outcome.errors) == (6, 6, 0, 0)
    h5 = read_table_h5(tmp_path / "out" / "sweep.h5")
    durations = h5["axes/motion.0.duration_s"]
    rates = h5["axes/imu.sample_rate_hz"]
    np.testing.assert_array_equal(durations, [1, 1, 2, 2, 3, 3])
    np.testing.assert_array_equal(rates, [10, 20, 10, 20, 10, 20])
    # simulate-table writes one sample per 1/rate: a hold 1 s longer adds `rate` samples
    samples = h5["results/samples"]
    duration = h5["results/duration_s"]
    np.testing.assert_allclose(samples, duration * rates, atol=0.5)
    np.testing.assert_allclose(np.diff(duration[::2]), [1.0, 1.0], atol=1e-9)
    assert list(h5["points/status"]) == ["passed"] * 6
    assert h5["checks/passed"].shape == (6, 1) and h5["checks/passed"].all()
    header = (tmp_path / "out" / "sweep.csv").read_text().splitlines()[0].split(",")
    assert header[:8] == [
        "id",
        "motion.0.duration_s",
        "imu.sample_rate_hz",
        "seed",
        "status",
        "passed",
        "error",
        "run_s",
    ]
    assert "samples" in header and "check[0]: samples > 10" in header
    overall = [s for s in outcome.aggregates.stats if s.group == "all" and s.result == "samples"]
    assert overall[0].n == 6 and overall[0].mean == pytest.approx(np.mean(samples))


def test_a_point_that_raises_is_recorded_and_the_others_run(sim_sweep, tmp_path, pool):
    # each value is valid with the others at their first value; 3 Hz with a 2 Hz
    # truth output is not (truth_rate_hz must divide the sample rate): raised at the point
    path = sim_sweep(grid={"imu.sample_rate_hz": [20, 3], "output.truth_rate_hz": [1, 2]})
    _, outcome = _run(path, tmp_path / "out", pool)
    assert outcome.errors == 1 and len(outcome.table.records) == 4
    bad = [r for r in outcome.table.records if r["status"] == "error"]
    assert bad[0]["index"] == 3 and "must divide" in bad[0]["error"]
    assert bad[0]["error_type"] == "InputError"
    rows = (tmp_path / "out" / "sweep.csv").read_text().splitlines()
    assert len(rows) == 5 and ",error," in rows[4]


def test_interrupted_sweep_resumes_without_redoing_points(sim_sweep, tmp_path, pool):
    path = sim_sweep()
    seen = []

    def stop_after_three(done, total, errors):
        seen.append(done)
        if done == 3:
            raise KeyboardInterrupt

    plan = load_sweep(path)
    with pytest.raises(KeyboardInterrupt):
        run_sweep(plan, tmp_path / "out", pool, progress=stop_after_three)
    journal = read_journal(tmp_path / "out")
    assert len(journal) == 3
    # the table was written with the finished points when interrupted
    assert len((tmp_path / "out" / "sweep.csv").read_text().splitlines()) == 4
    # a kill in the middle of a journal line: the partial line is ignored
    with (tmp_path / "out" / JOURNAL).open("a") as handle:
        handle.write('{"key": "cut sho')
    _, resumed = _run(path, tmp_path / "out", pool)
    assert (resumed.ran, resumed.skipped) == (3, 3)
    _run(path, tmp_path / "fresh", pool)
    assert _rows(tmp_path / "out") == _rows(tmp_path / "fresh")
    _, again = _run(path, tmp_path / "out", pool)
    assert (again.ran, again.skipped) == (0, 6)


def _rows(outdir):
    """CSV rows without the run-time columns (run_s, cpu_s)."""
    lines = (outdir / "sweep.csv").read_text().splitlines()
    cut = lines[0].split(",").index("run_s")
    return [line.split(",")[:cut] + line.split(",")[cut + 2 :] for line in lines]


def test_a_changed_sweep_is_not_mixed_into_an_old_folder(sim_sweep, tmp_path, pool):
    _run(sim_sweep(), tmp_path / "out", pool)
    changed = sim_sweep(set={"imu.gyro.arw_deg_rth": 0.02})
    with pytest.raises(InputError, match="different sweep"):
        _run(changed, tmp_path / "out", pool)
    _, outcome = _run(changed, tmp_path / "out", pool, restart=True)
    assert outcome.ran == 6


def test_check_naming_an_unknown_result_stops_after_the_first_point(sim_sweep, tmp_path, pool):
    path = sim_sweep(set={"checks": ["sampels > 10"]})
    with pytest.raises(InputError, match=r"unknown name 'sampels'.*did you mean 'samples'"):
        _run(path, tmp_path / "out", pool)
    assert read_journal(tmp_path / "out") == {}


def test_aggregate_naming_an_unknown_result_is_bad_input(sim_sweep, tmp_path, pool):
    path = sim_sweep(aggregate={"results": ["sample"]})
    with pytest.raises(InputError, match="unknown result 'sample'"):
        _run(path, tmp_path / "out", pool)


def test_keep_runs_writes_each_point(sim_sweep, tmp_path, pool):
    _, outcome = _run(
        sim_sweep(grid={"motion.0.duration_s": [1, 2]}), tmp_path / "o", pool, keep_runs=True
    )
    runs = sorted(p.name for p in (tmp_path / "o" / "runs").iterdir())
    assert runs == ["p00000", "p00001"]
    summary = json.loads((tmp_path / "o" / "runs" / "p00001" / "summary.json").read_text())
    assert summary["results"] == outcome.table.records[1]["results"]


@pytest.mark.slow
def test_resume_after_kill_9_of_the_sweep_process(sim_sweep, tmp_path, pool):
    import os
    import signal
    import subprocess
    import sys
    import time

    path = sim_sweep(grid={"motion.0.duration_s": [1, 2]}, seeds=20)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "inins", "sweep", str(path), "-o", str(out), "-j", "1"]
    child = subprocess.Popen(
        cmd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    try:
        for _ in range(2400):  # polls 50 ms apart: a bound on the wait, not a speed test
            if len(read_journal(out)) >= 3 or child.poll() is not None:
                break
            time.sleep(0.05)
        else:
            pytest.fail("the sweep did not finish 3 points")
    finally:
        os.killpg(child.pid, signal.SIGKILL)  # the sweep and its workers, mid-sweep
        child.wait()
    done_before = len(read_journal(out))
    assert 3 <= done_before < 40
    _, resumed = _run(path, out, pool)
    assert resumed.skipped >= done_before and resumed.ran + resumed.skipped == 40
    assert len(resumed.table.records) == 40 and resumed.errors == 0
    assert [r["index"] for r in resumed.table.records] == list(range(40))


def test_batch_size_gives_each_task_a_quarter_second_of_points():
    from inins.sweep.engine import batch_size

    assert batch_size(0.0, 0.05, 1000, 2) == 1  # local: one point a task
    assert batch_size(0.25, 0.0, 1000, 2) == 1  # no run time known yet
    assert batch_size(0.25, 0.05, 1000, 2) == 6  # 0.25 s / 0.05 s, rounded up
    assert batch_size(0.25, 1e-4, 100_000, 2) == 64  # capped
    assert batch_size(0.25, 0.01, 40, 2) == 5  # 40 points left: 4 tasks per slot
