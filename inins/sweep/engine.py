"""Run a sweep: skip the finished points, run the rest, journal each, write the table.

Order of work (:func:`run_sweep`):

1. the sweep folder's manifest must belong to this sweep (same command, base
   scenario text and ``set:``); ``restart`` forgets an earlier sweep instead;
2. points already in the journal are skipped (``retry_errors`` reruns those that
   raised);
3. when nothing has run yet, the first point runs alone: a check naming an
   unknown result, or an ``aggregate.results`` name no result carries, stops
   the sweep as bad input before the other points start;
4. the other points go to the executor, a few per worker in flight; each record
   is appended to the journal as it arrives, a point that raised included;
5. at the end, and on an interrupt, the table is rebuilt from the journal and
   written atomically (``sweep.csv``, ``sweep.h5``), with the aggregates
   (``aggregates.csv``, ``sweep.txt``).

Faults:

- one sweep at a time in a folder: the sweep holds an exclusive lock on
  ``OUTDIR/.sweep.lock`` from start to end; a second sweep into the folder is
  refused (bad input, exit 2) instead of running every point again; the lock
  goes with the process, however it ends;
- disk space: before anything is written the free space must hold the run's
  journal and table (:data:`RECORD_BYTES` a point until a point has run, then
  that point's own record and, with ``keep_runs``, its output folder) plus a
  margin sized to the estimate (:func:`inins.io.diskspace.margin_for`), checked
  again after the first point; a full disk met anyway stops the sweep with one
  message, the journal cut back to whole records (resumable);
- a point that cannot write its outputs (``keep_runs`` on a full or read-only
  disk) stops the sweep the same way; it is not journaled, so a resume reruns it.
"""

import collections
import contextlib
import json
import math
import os
import statistics
import time
from dataclasses import dataclass
from pathlib import Path

from inins.exceptions import InputError, OutputError
from inins.io import diskspace, sweep_files
from inins.sweep.aggregate import (
    Aggregates,
    aggregate,
    chosen_results,
    format_aggregates,
    stats_columns,
)
from inins.sweep.executors import finished as finished_batches
from inins.sweep.table import SweepTable, build_table, csv_columns, h5_groups, point_id
from inins.sweep.worker import STATUS_ERROR, PointTask, is_check_name_error

IN_FLIGHT_PER_WORKER = 2
RECORD_BYTES = 4096
"""Journal bytes a point is assumed to take before one has run (a record of a few
dozen results is 1-3 kB)."""
TABLE_COPIES = 3
"""Table bytes per journal byte when the table is rewritten: sweep.csv and sweep.h5
(each about a record's size a point), and the old pair beside the new until the
rename."""
LOCK = ".sweep.lock"


@dataclass(frozen=True)
class SweepOutcome:
    """A finished (or interrupted) sweep.

    Attributes
    ----------
    table : inins.sweep.table.SweepTable
    aggregates : inins.sweep.aggregate.Aggregates
    planned, ran, skipped, errors : int
        Points in the sweep, run now, found finished, that raised (in the table).
    paths : tuple of Path
        Files written.
    wall_s : float
    """

    table: SweepTable
    aggregates: Aggregates
    planned: int
    ran: int
    skipped: int
    errors: int
    paths: tuple
    wall_s: float

    @property
    def complete(self) -> bool:
        """True when every point of the sweep is in the table."""
        return len(self.table.records) == self.planned


def run_sweep(
    plan,
    outdir,
    executor,
    keep_runs=False,
    restart=False,
    retry_errors=False,
    progress=None,
) -> SweepOutcome:
    """Run ``plan`` (:func:`inins.sweep.plan.load_sweep`) into ``outdir``.

    Parameters
    ----------
    plan : SweepPlan
    outdir : Path
    executor : LocalExecutor or DaskExecutor
        Not yet entered; entered here only if there is work.
    keep_runs : bool
        Write each point's outputs under ``outdir/runs/<id>/``.
    restart, retry_errors : bool
    progress : callable, optional
        ``progress(done, total, errors)`` after each point (done counts skipped ones).
    """
    from inins.commands.execute import prepare_outdir

    start = time.perf_counter()
    outdir = prepare_outdir(outdir)
    with _FolderLock(outdir):
        table, aggs, paths, ran, skipped = _run_locked(
            plan, outdir, executor, keep_runs, restart, retry_errors, progress
        )
    errors = sum(r["status"] == STATUS_ERROR for r in table.records)
    return SweepOutcome(
        table, aggs, plan.size, ran, skipped, errors, paths, time.perf_counter() - start
    )


def _run_locked(plan, outdir, executor, keep_runs, restart, retry_errors, progress):
    finished = {} if restart else sweep_files.read_journal(outdir)
    todo = [p for p in plan.points() if _needs_run(finished.get(p.key), retry_errors)]
    room = _Room(outdir, plan.size, len(todo), keep_runs)
    room.check()
    _claim(outdir, plan, restart)
    finished = sweep_files.read_journal(outdir)
    skipped = plan.size - len(todo)
    tasks = _tasks(plan, todo, outdir, keep_runs)
    ran = 0
    try:
        if tasks:
            with sweep_files.Journal(outdir) as journal, executor as ex:
                ran = _dispatch(plan, tasks, ex, journal, finished, skipped, progress, room)
    except OutputError:
        # the disk is full (or the folder unwritable): the journal keeps the finished
        # points; write the table if it fits, else leave the one message
        with contextlib.suppress(OutputError):
            write_results(plan, outdir, sweep_files.read_journal(outdir))
        raise
    except BaseException:
        write_results(plan, outdir, sweep_files.read_journal(outdir))
        raise
    table, aggs, paths = write_results(plan, outdir, sweep_files.read_journal(outdir))
    return table, aggs, paths, ran, skipped


class _FolderLock:
    """Exclusive, non-blocking ``flock`` on ``OUTDIR/.sweep.lock`` for one sweep."""

    def __init__(self, outdir):
        self.path = Path(outdir) / LOCK
        self.fd = None

    def __enter__(self):
        import fcntl

        self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o666)
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            holder = os.pread(self.fd, 64, 0).decode("ascii", "replace").strip() or "?"
            os.close(self.fd)
            raise InputError(
                f"another sweep (process {holder}) is running in this folder; wait for it "
                "to finish (a rerun then resumes) or choose another -o",
                source=str(self.path.parent),
            ) from None
        os.ftruncate(self.fd, 0)
        os.pwrite(self.fd, f"{os.getpid()}\n".encode(), 0)
        return self

    def __exit__(self, *exc):
        os.close(self.fd)  # releases the lock; the file stays (unlinking it would race)
        return False


class _Room:
    """Free space for the rest of the sweep: journal records, the table, and the
    points' outputs with ``keep_runs`` (module docstring)."""

    def __init__(self, outdir, total, todo, keep_runs):
        self.outdir, self.total, self.todo, self.keep_runs = outdir, total, todo, keep_runs
        self.record_bytes, self.run_bytes, self.measured = RECORD_BYTES, 0, False

    def check(self, left=None):
        left = self.todo if left is None else left
        if not left:
            return
        need = left * (self.record_bytes + self.run_bytes)
        need += TABLE_COPIES * self.total * self.record_bytes
        per_point = diskspace.mib(self.record_bytes + self.run_bytes)
        basis = "measured on the first point" if self.measured else "estimated"
        diskspace.require_room(
            self.outdir,
            need,
            f"the sweep ({left} points to run at {per_point} each, {basis}, and the "
            f"table of {self.total} points)",
        )

    def measure(self, record, left):
        """Size the rest of the run on the first record of this run, and check again."""
        if self.measured:
            return
        self.measured = True
        self.record_bytes = len(json.dumps(record, allow_nan=False)) + 1
        if self.keep_runs:
            run_dir = Path(self.outdir) / "runs"
            sizes = (
                [
                    sum(f.stat().st_size for f in d.rglob("*") if f.is_file())
                    for d in run_dir.iterdir()
                    if d.is_dir()
                ]
                if run_dir.is_dir()
                else []
            )
            self.run_bytes = max(sizes, default=0)
        self.check(left)


def _stop_on_output_error(record) -> None:
    """A point that could not write its outputs: every later one would fail alike."""
    if record["status"] == STATUS_ERROR and record.get("error_type") == "OutputError":
        raise OutputError(
            f"point {record['index']}: {record['error']}; the sweep stopped, the points "
            "finished so far are kept, run the same command again to resume"
        )


def _needs_run(record, retry_errors) -> bool:
    return record is None or (retry_errors and record["status"] == STATUS_ERROR)


def _tasks(plan, points, outdir, keep_runs) -> list:
    """The :class:`PointTask` of each point (the folders resolved once for all)."""
    runs = Path(outdir).resolve() / "runs"
    base = None if plan.base is None else str(Path(plan.base).resolve())
    return [
        PointTask(
            point.key,
            point.index,
            plan.command,
            base,
            point.overrides,
            point.seed,
            str(runs / point_id(point.index, plan.size)) if keep_runs else None,
        )
        for point in points
    ]


def _claim(outdir, plan, restart) -> None:
    """Check (or write) the manifest: the folder holds this sweep or none."""
    manifest = {
        "command": plan.command,
        "fingerprint": plan.fingerprint(),
        "sweep": plan.source,
        "points": plan.size,
    }
    old = sweep_files.read_manifest(outdir)
    if restart:
        sweep_files.reset(outdir)
    elif old is not None and (
        old.get("command") != plan.command or old.get("fingerprint") != plan.fingerprint()
    ):
        raise InputError(
            "this output folder holds the results of a different sweep (command, base "
            "scenario or set: changed); use --restart to discard them, or another -o",
            source=str(outdir),
        )
    sweep_files.write_manifest(outdir, manifest)


def _dispatch(plan, tasks, ex, journal, finished, skipped, progress, room) -> int:
    """Run ``tasks`` on ``ex``; journal every record; return how many ran."""
    total, done = plan.size, skipped
    errors = sum(r["status"] == STATUS_ERROR for r in finished.values())
    queue = list(reversed(tasks))
    if not finished:  # the probe: bad checks or aggregate names stop everything
        record = _run_alone(ex, queue.pop())
        _stop_on_output_error(record)
        _probe(plan, record)
        journal.append(record)
        room.measure(record, len(queue))
        done, errors = done + 1, errors + (record["status"] == STATUS_ERROR)
        if progress:
            progress(done, total, errors)
    ran = done - skipped
    recent = collections.deque(maxlen=16)  # run times of the last points (s)

    def batches():
        while queue:
            run_s = statistics.median(recent) if recent else 0.0
            size = batch_size(ex.batch_s, run_s, len(queue), ex.slots)
            yield tuple(queue.pop() for _ in range(min(size, len(queue))))

    for records in finished_batches(ex, batches(), IN_FLIGHT_PER_WORKER * ex.slots):
        for record in records:
            _stop_on_output_error(record)
            journal.append(record)
            ran, done = ran + 1, done + 1
            room.measure(record, len(tasks) - ran)
            if math.isfinite(record["run_s"]):
                recent.append(record["run_s"])
            errors += record["status"] == STATUS_ERROR
        if progress:
            progress(done, total, errors)
    return ran


def batch_size(batch_s: float, run_s: float, remaining: int, slots: int) -> int:
    """Points per task: enough for ``batch_s`` of work at ``run_s`` a point (from the
    last points; 0 before any finished), at most 64, and few enough that every slot
    gets a few tasks."""
    if batch_s <= 0 or not run_s > 0:
        return 1
    wanted = int(batch_s / run_s) + 1
    return max(1, min(wanted, 64, remaining // (4 * max(slots, 1)) or 1))


def _run_alone(ex, task) -> dict:
    return next(finished_batches(ex, [(task,)], 1))[0]


def _probe(plan, record) -> None:
    """Stop on bad input that every point shares."""
    if is_check_name_error(record):
        raise InputError(f"{record['error']} (in the first point)", source=plan.source)
    names = plan.aggregate.results or []
    known = record["results"]
    unknown = [n for n in names if n not in known]
    if known and unknown:
        raise InputError(
            f"unknown result {unknown[0]!r} (results: {', '.join(known)})",
            source=plan.source,
            key="aggregate.results",
        )


def write_results(plan, outdir, finished):
    """Rebuild the table from the journal and write table, aggregates and report."""
    table = build_table(plan, finished)
    settings = plan.aggregate
    # names no point produced were refused by the probe; never fail while writing
    wanted = settings.results and [n for n in settings.results if n in table.result_names]
    names = chosen_results(table, wanted or None) if table.records else []
    aggs = aggregate(table, names, settings.percentiles)
    outdir = Path(outdir)
    sweep_files.write_table_csv(outdir / sweep_files.TABLE_CSV, csv_columns(table))
    groups, attrs = h5_groups(table, plan)
    groups["aggregates"] = stats_columns(aggs)
    sweep_files.write_table_h5(outdir / sweep_files.TABLE_H5, groups, attrs)
    sweep_files.write_table_csv(outdir / "aggregates.csv", stats_columns(aggs))
    report = (
        f"inins sweep {plan.source}: {plan.command}, {len(table.records)} of {plan.size} "
        f"points finished\n\n{format_aggregates(aggs)}\n"
    )
    from inins.io.atomic import write_text_atomic

    write_text_atomic(outdir / "sweep.txt", report)
    names = (sweep_files.TABLE_CSV, sweep_files.TABLE_H5, "aggregates.csv", "sweep.txt")
    return table, aggs, tuple(outdir / n for n in names)
