"""Sweep faults as real processes meet them: a full disk (a small tmpfs), ``kill -9``
of the sweep, and a second sweep into a busy folder."""

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from inins.io import sweep_files
from inins.sweep.engine import _FolderLock
from tests.sweep.conftest import TINY_SIMULATE, write_sweep

ROOT = Path(__file__).resolve().parents[2]


def _sweep(folder, points, **extra):
    content = {
        "command": "simulate-table",
        "base": str(TINY_SIMULATE),
        "seeds": points,
    }
    content.update(extra)
    return write_sweep(folder, **content)


def _inins(*args, **kwargs):
    return subprocess.run(
        [sys.executable, "-m", "inins", *map(str, args)],
        capture_output=True,
        text=True,
        check=False,
        cwd=ROOT,
        **kwargs,
    )


@pytest.fixture
def small_disk(tmp_path):
    """A tmpfs mounted on a fresh folder (``mount(size)`` mounts or resizes it);
    skipped where this process may not mount (not root, no CAP_SYS_ADMIN)."""
    where = tmp_path / "disk"
    where.mkdir()
    mounted = []

    def mount(size):
        options = f"size={size}" if not mounted else f"remount,size={size}"
        done = subprocess.run(
            ["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(where)],
            capture_output=True,
            text=True,
            check=False,
        )
        if done.returncode != 0:
            pytest.skip(f"cannot mount a tmpfs here ({done.stderr.strip()})")
        mounted.append(size)
        return where

    yield mount
    if mounted:
        subprocess.run(["umount", "-l", str(where)], check=False)


def _leftovers(folder):
    return sorted(p.name for p in Path(folder).rglob("*") if ".partial-" in p.name)


def test_a_sweep_that_does_not_fit_is_refused_before_it_writes(tmp_path, small_disk):
    disk = small_disk("1m")
    out = disk / "out"
    done = _inins("sweep", _sweep(tmp_path, 8), "-o", out, "-j", "1")
    assert done.returncode == 2, done.stdout + done.stderr
    message = done.stderr.strip()
    assert len(message.splitlines()) == 1, message
    assert "not enough free space" in message and "plus a margin of 1.0 MiB" in message
    assert "8 points to run" in message
    assert sorted(p.name for p in out.iterdir()) == [".sweep.lock"]


def test_a_full_disk_mid_sweep_stops_with_one_message_and_resumes(tmp_path, small_disk):
    # each kept run writes ~0.1 MiB; the estimate before the first point (journal and
    # table only) fits, the one measured on it does not: the sweep stops after it
    disk = small_disk("3m")
    out = disk / "out"
    sweep = _sweep(tmp_path, 40)
    done = _inins("sweep", sweep, "-o", out, "-j", "1", "--keep-runs")
    assert done.returncode == 2, done.stdout + done.stderr
    message = done.stderr.strip()
    assert len(message.splitlines()) == 1, message
    assert "measured on the first point" in message and "39 points to run" in message
    assert "Traceback" not in done.stdout + done.stderr
    assert _leftovers(disk) == []
    journal = sweep_files.read_journal(out)
    assert len(journal) == 1
    assert (out / sweep_files.JOURNAL).read_text().count("\n") == 1

    small_disk("64m")  # room made: the rerun resumes from the journal
    done = _inins("sweep", sweep, "-o", out, "-j", "1", "--keep-runs")
    assert done.returncode == 0, done.stdout + done.stderr
    assert "39 run, 1 already finished" in done.stdout
    assert len(sweep_files.read_journal(out)) == 40


def test_the_journal_keeps_whole_records_when_the_disk_fills(small_disk):
    from inins.exceptions import OutputError

    disk = small_disk("256k")
    with sweep_files.Journal(disk) as journal:
        journal.append({"key": "a", "status": "passed"})
        with contextlib.suppress(OSError), open(disk / "filler", "wb") as filler:
            while True:  # fill the disk to its last block
                filler.write(b"\0" * 4096)
                filler.flush()
        with pytest.raises(OutputError, match=r"no space left on tmpfs.*resume"):
            journal.append({"key": "b", "status": "passed", "pad": "x" * 20000})
    assert (disk / sweep_files.JOURNAL).read_text() == '{"key": "a", "status": "passed"}\n'
    assert list(sweep_files.read_journal(disk)) == ["a"]


def _descendants(pid):
    """Pids of every process below ``pid`` (read from /proc)."""
    children = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            with contextlib.suppress(OSError, IndexError):
                ppid = int((entry / "stat").read_bytes().rsplit(b")", 1)[1].split()[1])
                children.setdefault(ppid, []).append(int(entry.name))
    found, todo = [], [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            found.append(child)
            todo.append(child)
    return found


def _running(pid):
    try:
        state = Path(f"/proc/{pid}/stat").read_bytes().rsplit(b")", 1)[1].split()[0]
    except OSError:
        return False
    return state != b"Z"


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
def test_kill_9_of_a_sweep_leaves_no_worker_behind(tmp_path):
    out = tmp_path / "out"
    sweep = _sweep(tmp_path, 2000)  # far more than run before the kill
    process = subprocess.Popen(
        [sys.executable, "-m", "inins", "sweep", str(sweep), "-o", str(out), "-j", "2"],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        journal = out / sweep_files.JOURNAL
        for _ in range(600):  # the workers run points once the journal grows
            if journal.is_file() and journal.read_text().count("\n") >= 5:
                break
            time.sleep(0.1)
        else:
            pytest.fail("the sweep ran no point")
        workers = _descendants(process.pid)
        assert len(workers) >= 2  # forkserver and workers
        os.kill(process.pid, signal.SIGKILL)
        process.wait()
        for _ in range(100):
            alive = [pid for pid in workers if _running(pid)]
            if not alive:
                break
            time.sleep(0.1)
        assert alive == []
    finally:
        process.kill()
        for pid in _descendants(process.pid):
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)
    records = sweep_files.read_journal(out)
    assert len(records) >= 5  # the journal survives the kill


def test_a_second_sweep_into_a_busy_folder_is_refused(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    sweep = _sweep(tmp_path, 3)
    with _FolderLock(out):  # a sweep running there (this process holds its lock)
        done = _inins("sweep", sweep, "-o", out, "-j", "1")
        assert done.returncode == 2, done.stdout + done.stderr
        assert f"another sweep (process {os.getpid()}) is running" in done.stderr
        assert not (out / sweep_files.JOURNAL).exists()
    done = _inins("sweep", sweep, "-o", out, "-j", "1")  # the lock went with its holder
    assert done.returncode == 0, done.stdout + done.stderr
    assert json.loads((out / sweep_files.MANIFEST).read_text())["points"] == 3
