"""Run a generator ahead in a second thread: its next items are computed while the
caller works on the current one.

A simulated flight produces its IMU stream (the truth quadrature and the sensor
errors, compiled kernels that release the GIL) while the filter consumes the
previous chunks: on two cores the two overlap. The items and their order are the
generator's own, so the results are bit for bit those of the plain generator; an
exception raised in it is raised in the caller at the item where it happened.
"""

import queue
import threading

_DONE = object()


def ahead(items, depth):
    """Yield the items of ``items`` (an iterable), computed up to ``depth`` ahead in a
    daemon thread.

    Parameters
    ----------
    items : iterable
        Consumed only by the thread (a generator must not be used elsewhere).
    depth : int
        Items held ready at most (>= 1): the memory the lead may take.

    Yields
    ------
    The items of ``items``, in order. Closing this generator early (the caller
    stops or raises) stops the thread at its next item.
    """
    ready = queue.Queue(maxsize=depth)
    stop = threading.Event()

    def put(entry):
        while not stop.is_set():
            try:
                ready.put(entry, timeout=0.1)
                return True
            except queue.Full:
                continue
        return False

    def produce():
        try:
            for item in items:
                if not put((item, None)):
                    return
        except BaseException as exc:  # handed to the caller, raised there
            put((_DONE, exc))
            return
        put((_DONE, None))

    thread = threading.Thread(target=produce, name="inins-ahead", daemon=True)
    thread.start()
    try:
        while True:
            item, error = ready.get()
            if item is _DONE:
                if error is not None:
                    raise error
                return
            yield item
    finally:
        stop.set()
