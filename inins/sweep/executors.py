"""Where sweep points run: local worker processes, or a Dask cluster.

Both give the same interface (a context manager): ``submit(batch) -> future`` (a
batch is a tuple of :class:`~inins.sweep.worker.PointTask`, run in order by one
worker), ``wait_any(futures) -> (done, pending)``, ``outcome(future) -> (records,
resubmitted future or None)``. ``outcome`` turns a lost worker into error records
after the retries. :func:`finished` is the one loop over them that sweeps and
``inins check`` share: submit, wait, resubmit, hand back each batch's records.
``batch_s`` is the run time a batch should last: 0 (one point a
task) locally, where dispatch costs well under a millisecond; 0.25 s on Dask, whose
scheduler costs a few milliseconds a task.

Local
    A :class:`concurrent.futures.ProcessPoolExecutor` of ``workers`` processes
    (``forkserver`` start, so the parent's threads are not forked; one BLAS
    thread each). Each worker imports the command module once and ignores SIGINT:
    Ctrl-C goes to the parent,
    which stops handing out points. A worker that dies (killed, out of memory)
    breaks the pool: the pool is rebuilt and the points in flight are resubmitted,
    each at most :data:`MAX_ATTEMPTS` times.
Dask
    A ``distributed.Client`` on an existing scheduler (``tcp://HOST:PORT``). The
    workers need inins installed and must see the base scenario (and its data) at
    the same path; a point whose worker is lost is rerun by the scheduler, and
    recorded as an error when the scheduler gives up (``KilledWorker``).
"""

import os
import uuid
from concurrent import futures as cf

from inins.exceptions import InputError
from inins.sweep.worker import STATUS_ERROR, PointTask, run_points, warm_up

MAX_ATTEMPTS = 3
BLAS_THREADS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
"""One BLAS thread a worker (unless the user set them): the workers are the
parallelism, and two workers each starting a BLAS thread per core would fight for
the cores over every small matrix product."""


def default_workers() -> int:
    """Cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover (not Linux)
        return os.cpu_count() or 1


def lost_record(task: PointTask, message: str) -> dict:
    """Error record of a point whose worker was lost."""
    return {
        "key": task.key,
        "index": task.index,
        "seed": task.seed,
        "status": STATUS_ERROR,
        "error": message,
        "error_type": "WorkerLost",
        "error_key": None,
        "results": {},
        "truth": {},
        "checks": [],
        "run_s": float("nan"),
        "cpu_s": float("nan"),
    }


def start_server(command: str | None = None):
    """Start the process the local workers are forked from (``forkserver``), and
    return the multiprocessing context.

    The server imports numpy, numba, the runner and ``command``'s module (scenario
    model, writers) once, while the caller goes on (loading the sweep, checking
    the folder): every worker then starts with them imported, in a few
    milliseconds. Idempotent; a later call's ``command`` is imported by the
    workers themselves.
    """
    import multiprocessing
    from multiprocessing import forkserver

    preload = ["numpy", "numba", "inins.commands.execute"]
    if command is not None:
        from inins.commands import find_command

        try:
            preload.append(find_command(command).module_name)
        except InputError:
            pass  # the sweep file's own error is reported where it is loaded
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(preload)
    for name in BLAS_THREADS:  # read by the server process as it starts
        os.environ.setdefault(name, "1")
    forkserver.ensure_running()
    return ctx


def finished(ex, batches, in_flight):
    """Run ``batches`` on the entered executor ``ex``; yield each batch's records as it
    finishes.

    Parameters
    ----------
    ex : LocalExecutor or DaskExecutor
        Entered (``with``).
    batches : iterable of tuple of PointTask
        Pulled one at a time as a slot frees (a generator may size the next batch on
        the records seen so far).
    in_flight : int
        Batches submitted at a time.

    Yields
    ------
    list of dict
        The worker records of one batch, in its order (a batch whose worker was lost is
        resubmitted by ``ex.outcome``; after the retries its records are errors).
    """
    source = iter(batches)
    pending, more = set(), True
    while True:
        while more and len(pending) < in_flight:
            batch = next(source, None)
            if batch is None:
                more = False
            else:
                pending.add(ex.submit(batch))
        if not pending:
            return
        done, pending = ex.wait_any(pending)
        for future in done:
            records, retry = ex.outcome(future)
            if retry is not None:
                pending.add(retry)
            else:
                yield records


class LocalExecutor:
    """Points on ``workers`` local processes.

    Parameters
    ----------
    workers : int
    command : str or None
        Imported once by every worker at start (None: on its first point).
    keep_open : bool
        Keep the workers between sweeps (``with`` blocks) until :meth:`close`.
    """

    def __init__(self, workers: int, command: str | None, keep_open: bool = False):
        if workers < 1:
            raise InputError(f"--workers must be >= 1, got {workers}", key="--workers")
        self.workers, self.command, self.keep_open = workers, command, keep_open
        self.slots = workers
        self.batch_s = 0.0
        self.pool = None
        self._tasks = {}  # future -> (task, attempt, pool)

    def __enter__(self):
        if self.pool is None:
            self._start()
        return self

    def close(self) -> None:
        """Stop the workers (an executor made with ``keep_open``)."""
        if self.pool is not None:
            self.pool.shutdown(wait=True, cancel_futures=True)
            self.pool = None

    def _start(self):
        ctx = start_server(self.command)
        self.pool = cf.ProcessPoolExecutor(
            self.workers,
            mp_context=ctx,
            initializer=warm_up,
            initargs=(self.command, True, os.getpid()),
        )

    def __exit__(self, exc_type, exc, tb):
        if exc_type is not None:
            for future in list(self._tasks):
                future.cancel()
            self._tasks.clear()
        if not self.keep_open:
            self.pool.shutdown(wait=exc_type is None, cancel_futures=True)
            self.pool = None

    def submit(self, batch: tuple, attempt: int = 1):
        future = self.pool.submit(run_points, batch)
        self._tasks[future] = (batch, attempt, self.pool)
        return future

    @staticmethod
    def wait_any(pending):
        done, rest = cf.wait(pending, return_when=cf.FIRST_COMPLETED)
        return done, rest

    def outcome(self, future):
        """``(records, None)``, or ``(None, new future)`` when the batch was resubmitted."""
        batch, attempt, pool = self._tasks.pop(future)
        try:
            return future.result(), None
        except cf.process.BrokenProcessPool:
            if pool is self.pool:  # rebuild once for all the futures of the broken pool
                self.pool.shutdown(wait=False, cancel_futures=True)
                self._start()
            if attempt >= MAX_ATTEMPTS:
                message = f"the worker process died {attempt} times"
                return [lost_record(task, message) for task in batch], None
            return None, self.submit(batch, attempt + 1)


class DaskExecutor:
    """Points on an existing Dask cluster.

    Parameters
    ----------
    address : str
        ``tcp://HOST:PORT`` of the scheduler.
    command : str
    timeout_s : float
        How long to wait for the scheduler before giving up (bad input).
    """

    def __init__(self, address: str, command: str, timeout_s: float = 10.0):
        try:
            import distributed
        except ImportError:
            raise InputError(
                "--scheduler needs dask.distributed: pip install 'inins[cluster]'",
                key="--scheduler",
            ) from None
        self.distributed = distributed
        self.address, self.command, self.timeout_s = address, command, timeout_s
        self.client = None
        self.slots = 1
        self.batch_s = 0.25
        self._tasks = {}

    def __enter__(self):
        try:
            self.client = self.distributed.Client(self.address, timeout=self.timeout_s)
        except (OSError, TimeoutError, ValueError) as exc:
            raise InputError(
                f"cannot reach the Dask scheduler at {self.address} ({exc})", key="--scheduler"
            ) from None
        if not self.client.scheduler_info().get("workers"):
            self.client.close()
            raise InputError(
                f"the Dask scheduler at {self.address} has no workers", key="--scheduler"
            )
        self._completed = self.distributed.as_completed()
        self.client.run(warm_up, self.command, False)
        workers = self.client.scheduler_info()["workers"].values()
        self.slots = sum(w.get("nthreads", 1) for w in workers)
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is not None:
            self.client.cancel(list(self._tasks))
        self.client.close()

    def submit(self, batch: tuple, attempt: int = 1):
        key = f"inins-points-{batch[0].index}-{uuid.uuid4().hex}"
        future = self.client.submit(run_points, batch, pure=False, key=key)
        self._tasks[future] = batch
        self._completed.add(future)
        return future

    def wait_any(self, pending):
        first = next(self._completed)
        done = {first, *self._completed.next_batch(block=False)}
        return done, set(pending) - done

    def outcome(self, future):
        batch = self._tasks.pop(future)
        try:
            return future.result(), None
        except Exception as exc:  # KilledWorker, a worker lost too often
            return [lost_record(task, f"{type(exc).__name__}: {exc}") for task in batch], None
