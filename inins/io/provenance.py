"""Provenance of a run: what made a results file, recorded as root attributes."""

import os
import platform
from datetime import UTC, datetime

PROVENANCE_KEYS = (
    "inins_version",
    "command",
    "created_utc",
    "scenario_yaml",
    "scenario_source",
    "scenario_overrides",
    "seed",
    "python_version",
    "numpy_version",
    "h5py_version",
    "platform",
)
"""Root attributes every results file carries (plus ``summary_json``)."""


def utc_now() -> str:
    """Current UTC time, ISO 8601 to the second: ``2025-01-31T12:00:00Z``."""
    return datetime.now(UTC).isoformat(timespec="seconds").replace("+00:00", "Z")


def make_provenance(command, scenario_yaml, scenario_source, seed, overrides=()) -> dict:
    """Provenance attributes of one run.

    Parameters
    ----------
    command : str
    scenario_yaml : str
        The scenario text after overrides.
    scenario_source : str
        Scenario file name (``configs/<command>/default.yaml`` for a shipped one).
    seed : int
        The seed actually used.
    overrides : sequence of str
        The ``--set`` items, in order.

    Returns
    -------
    dict
        Keys :data:`PROVENANCE_KEYS`.
    """
    import h5py
    import numpy as np

    import inins

    return {
        "inins_version": inins.__version__,
        "command": command,
        "created_utc": utc_now(),
        "scenario_yaml": scenario_yaml,
        "scenario_source": scenario_source,
        "scenario_overrides": list(overrides),
        "seed": int(seed),
        "python_version": platform.python_version(),
        "numpy_version": np.__version__,
        "h5py_version": h5py.__version__,
        "platform": _platform(),
    }


def _platform():
    """``platform.platform()``'s string (``Linux-6.1.0-x86_64-with-glibc2.36``) without its
    ``uname -p`` subprocess (8 ms of every run): system, release and machine from
    ``os.uname``, the C library from ``confstr`` where the system has one."""
    u = platform.uname()
    text = f"{u.system}-{u.release}-{u.machine}"
    try:
        libc = os.confstr("CS_GNU_LIBC_VERSION")
    except (AttributeError, ValueError, OSError):
        libc = None
    return f"{text}-with-{libc.replace(' ', '')}" if libc else text
