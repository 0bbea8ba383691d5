"""Real processes (issue 18, item 4): a closed standard output ends a run quietly with
its own exit code; SIGHUP is handled like SIGTERM; Ctrl-C stops ``inins check`` at
once, lists the finished scenarios and exits 130."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
CONFIGS = ROOT / "configs"
INS = [sys.executable, "-m", "inins"]


def _closed_stdout(args, cwd, timeout=300):
    """Run ``inins ARGS`` with a pipe for stdout whose reader reads one line and goes
    away (``| head -1``); return (exit code, stderr)."""
    p = subprocess.Popen(
        [*INS, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=cwd, text=True
    )
    p.stdout.readline()
    p.stdout.close()
    with p.stderr:
        err = p.stderr.read()
    return p.wait(timeout=timeout), err


def test_check_into_a_closed_pipe_ends_with_its_exit_code(tmp_path):
    code, err = _closed_stdout(["check", str(CONFIGS / "observability"), "-j", "1"], tmp_path)
    assert code == 0, err
    assert "Traceback" not in err and "BrokenPipe" not in err


def test_show_and_schema_into_a_closed_pipe(tmp_path):
    from inins.commands import find_command
    from inins.commands.execute import execute
    from inins.io.resources import config_path

    out = tmp_path / "o"  # the file to show: written in-process (not what is tested here)
    execute(find_command("observability"), config_path("observability"), (), outdir=out)
    code, err = _closed_stdout(["show", str(out / "observability.h5")], tmp_path)
    assert code == 0 and "Traceback" not in err, err
    code, err = _closed_stdout(["schema", "run-ekf"], tmp_path)
    assert code == 0 and "Traceback" not in err, err


def test_a_run_into_a_closed_pipe_completes_its_files(tmp_path):
    out = tmp_path / "o"
    code, err = _closed_stdout(
        ["import-flight", str(CONFIGS / "import-flight" / "psins-tc.yaml"), "-o", str(out)],
        tmp_path,
    )
    assert code == 0 and "Traceback" not in err, err
    assert sorted(p.name for p in out.iterdir()) == [
        "import-flight.h5",
        "import-flight.txt",
        "summary.json",
    ]


@pytest.mark.parametrize("sig", [signal.SIGHUP, signal.SIGTERM])
def test_sighup_like_sigterm_leaves_nothing(tmp_path, sig):
    out = tmp_path / "o"
    long_flight = (  # four hours' flight: seconds of work, so the signal finds it running
        *("--set", "flight.legs=[{kind: wait, duration_s: 14400}]"),
        *("--set", "filter.turning_from_s=0"),
    )
    p = subprocess.Popen(
        [*INS, "run-ekf", str(CONFIGS / "run-ekf" / "default.yaml"), *long_flight, "-o", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    for _ in range(600):  # a hang guard by poll count: the run has made its folder
        if out.exists() or p.poll() is not None:
            break
        time.sleep(0.2)
    assert p.poll() is None, "the run ended before it could be interrupted"
    p.send_signal(sig)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 130, err
    assert "interrupted" in err
    assert not out.exists() or [q.name for q in out.iterdir()] == []


def test_ctrl_c_stops_check_and_lists_the_finished(tmp_path):
    p = subprocess.Popen(
        [*INS, "check", str(CONFIGS / "observability"), str(CONFIGS / "paper003"), "-j", "1"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    first = p.stdout.readline()  # "checking N scenarios"
    assert first.startswith("checking")
    line = p.stdout.readline()  # the first finished scenario
    assert line.startswith("[1/"), line
    os.killpg(p.pid, signal.SIGINT)
    _, err = p.communicate(timeout=60)  # a hang guard: the workers are stopped, not awaited
    assert p.returncode == 130, err
    assert "interrupted" in err and "scenarios finished" in err
