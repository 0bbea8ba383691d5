"""Compiled kernels: numba's ``njit`` with its on-disk cache, loaded on first call.

Kernel modules decorate with :func:`njit` (the options of ``numba.njit``; the cache is
always on) instead of importing numba. Nothing of numba is loaded until a kernel is
called, so a run that computes no kernel (``inins schema``, a scenario refused as bad
input, the pure-numpy paths) never pays numba's start-up (about 0.5 s of CPU).

Cache key. numba stamps a cached kernel with its own file's modification time and
size. A kernel that calls or inlines one from another module would then keep running
the old callee after an edit (or an upgrade) of that module only. So every ``inins``
kernel is cached in a folder named after one hash of all the kernel sources
(:func:`kernel_sources`: the kernel modules and every ``inins`` module they import):
an edit anywhere in them starts a new folder and every kernel compiles again, once;
an edit elsewhere (commands, CLI, I/O) keeps them. The folder is given to numba
through its public setting ``numba.config.CACHE_DIR`` while the kernels' dispatchers
are made (``NUMBA_CACHE_DIR``, the environment variable, is the base when set).
numba keys each entry further by the processor, so a cache is never used on a
processor it was not compiled for.

A compile (not a cache load) is reported to the :func:`on_compile` listeners
through numba's event API: the command line says what it compiles.
"""

import functools
import hashlib
import json
import os
import re
import sys
import threading
import time
from pathlib import Path

__all__ = ["activate", "cache_dir", "kernel_sources", "njit", "on_compile", "source_digest"]

_PACKAGE = Path(__file__).resolve().parents[1]
_LOCK = threading.RLock()
_PENDING = []
"""Kernels made before numba was loaded; given their dispatchers by :func:`activate`."""
_numba = None
_digest = None
_listeners = []


def njit(function=None, **options):
    """Decorator like ``numba.njit(cache=True, **options)``, compiling on first call.

    Usable as ``@njit``, ``@njit(**options)`` or ``njit(**options)(function)``.
    """
    options = {"cache": True, **options}

    def decorate(fn):
        with _LOCK:
            if _numba is not None:
                return _dispatcher(fn, options)
            kernel = Kernel(fn, options)
            _PENDING.append(kernel)
            return kernel

    return decorate if function is None else decorate(function)


class Kernel:
    """A function numba compiles (or loads from its cache) on its first call.

    Attributes other than ``py_func`` (``signatures``, ``inspect_types``, ...) are the
    dispatcher's and load numba.
    """

    _dispatcher = None

    def __init__(self, function, options):
        functools.update_wrapper(self, function)
        self.py_func = function
        self._options = options

    def __call__(self, *args):
        if self._dispatcher is None:
            activate()
        return self._dispatcher(*args)

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        activate()
        return getattr(self._dispatcher, name)

    def __repr__(self):
        return f"<inins kernel {self.py_func.__module__}.{self.py_func.__qualname__}>"


def _dispatcher(fn, options):
    """numba's cached dispatcher of ``fn``, its cache in :func:`cache_dir`."""
    config = _numba.config
    saved = config.CACHE_DIR
    config.CACHE_DIR = str(cache_dir())
    try:
        return _numba.njit(**options)(fn)
    finally:
        config.CACHE_DIR = saved


def activate():
    """Load numba and give every kernel its dispatcher; return the numba module.

    Module globals of ``inins`` that hold a :class:`Kernel` are replaced by its
    dispatcher, so that numba, compiling one kernel, sees the others it calls as its
    own (and inlines those marked ``inline="always"``). Idempotent and thread-safe.
    """
    global _numba
    if _numba is not None:
        return _numba
    with _LOCK:
        if _numba is not None:
            return _numba
        import numba

        _numba = numba
        _prune_other_caches()
        _forward_compile_events(numba)
        for kernel in _PENDING:
            kernel._dispatcher = _dispatcher(kernel.py_func, kernel._options)
        for name, module in list(sys.modules.items()):
            if name == "inins" or name.startswith("inins."):
                space = vars(module)
                for key, value in list(space.items()):
                    if isinstance(value, Kernel):
                        space[key] = value._dispatcher
        _PENDING.clear()
    return _numba


def cache_dir() -> Path:
    """numba's cache folder of the ``inins`` kernels: ``kernels-<digest>`` (the first
    16 hex digits of :func:`source_digest`) in ``$NUMBA_CACHE_DIR/inins`` when that is
    set, else in the package's ``__pycache__`` when it is writable, else in the user's
    cache folder (``$XDG_CACHE_HOME/inins`` or ``~/.cache/inins``)."""
    return _cache_base() / f"kernels-{source_digest()[:16]}"


def _cache_base() -> Path:
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"]) / "inins"
    here = _PACKAGE / "__pycache__"
    if os.access(here if here.is_dir() else _PACKAGE, os.W_OK):
        return here
    home = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(home) / "inins"


def _prune_other_caches() -> None:
    """Remove the cache folders of other kernel sources (an edit or an upgrade made
    them stale) once this one is new."""
    import shutil

    current = cache_dir()
    if current.exists():
        return
    for old in current.parent.glob("kernels-*"):
        if old != current and old.is_dir():
            shutil.rmtree(old, ignore_errors=True)


def kernel_sources() -> list[str]:
    """Package-relative paths of every source compiled code can depend on.

    The kernel modules (the modules that use :func:`njit`) and, transitively, every
    module of ``inins`` they import: the kernels a kernel calls or inlines and the
    module constants numba freezes into the machine code. Found by reading the
    sources (``import`` statements), so the set does not depend on which modules a
    process happens to have imported.
    """
    found = set()
    todo = [
        path
        for path in sorted(_PACKAGE.rglob("*.py"))
        if "__pycache__" not in path.parts and "njit" in path.read_text(encoding="utf-8")
    ]
    while todo:
        path = todo.pop()
        if path not in found:
            found.add(path)
            todo.extend(_imported_files(path))
    found.discard(Path(__file__).resolve())  # the machinery: options are in the modules
    return sorted(p.relative_to(_PACKAGE).as_posix() for p in found)


_FROM_IMPORT = re.compile(
    r"^[ \t]*from[ \t]+(\.*[\w.]*)[ \t]+import[ \t]+(\([^)]*\)|[^\n#]*)", re.M
)
_IMPORT = re.compile(r"^[ \t]*import[ \t]+([\w., \t]+)", re.M)


def _imported_files(path):
    """Sources of the ``inins`` modules that the module at ``path`` imports (its
    ``import`` lines, read as text: a line in a docstring only adds a file)."""
    text = path.read_text(encoding="utf-8")
    package = ".".join((_PACKAGE.name, *path.relative_to(_PACKAGE).parent.parts))
    names = []
    for line in _IMPORT.finditer(text):
        names += [part.split()[0] for part in line.group(1).split(",") if part.strip()]
    for line in _FROM_IMPORT.finditer(text):
        module = line.group(1)
        level = len(module) - len(module.lstrip("."))
        if level:
            anchor = package.rsplit(".", level - 1)[0] if level > 1 else package
            module = f"{anchor}.{module[level:]}" if module[level:] else anchor
        members = line.group(2).strip("() \n").replace("\n", ",").split(",")
        names.append(module)
        names += [f"{module}.{m.split()[0]}" for m in members if m.strip()]
    files = []
    for name in names:
        parts = name.split(".")
        for i in range(2, len(parts) + 1):  # inins.core/__init__ and inins.core.earth
            found = _module_file(parts[:i])
            if found is not None:
                files.append(found)
    return files


def _module_file(parts):
    """Source of module ``inins.<parts[1:]>`` in this package, or None."""
    if parts[0] != _PACKAGE.name:
        return None
    base = _PACKAGE.joinpath(*parts[1:])
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def source_digest() -> str:
    """One sha256 of the sources of :func:`kernel_sources` (computed once a process).

    Reading and hashing the sources costs a run about 40 ms; the digest is kept in
    ``sources.json`` beside the cache folders, under a key of every package source's
    size and modification time (as Python's bytecode cache checks a source), and read
    from there while none of them changed.
    """
    global _digest
    if _digest is None:
        stats = _source_stats()
        memo = _cache_base() / "sources.json"
        try:
            kept = json.loads(memo.read_text())
            if kept.get("stats") == stats:
                _digest = kept["digest"]
                return _digest
        except (OSError, ValueError, KeyError, AttributeError):
            pass
        digest = hashlib.sha256()
        for name in kernel_sources():
            digest.update(f"{name}\n".encode())
            digest.update(hashlib.sha256((_PACKAGE / name).read_bytes()).digest())
        _digest = digest.hexdigest()
        _write_memo(memo, {"stats": stats, "digest": _digest})
    return _digest


def _source_stats() -> str:
    """A hash of the path, size and modification time of every source of the package."""
    found = []
    for folder, dirs, files in os.walk(_PACKAGE):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        for name in sorted(files):
            if name.endswith(".py"):
                st = os.stat(os.path.join(folder, name))
                found.append(f"{folder}/{name}:{st.st_size}:{st.st_mtime_ns}")
    return hashlib.sha256("\n".join(found).encode()).hexdigest()


def _write_memo(path: Path, content: dict) -> None:
    """Write ``content`` as JSON to ``path`` through a temporary file (best effort: a
    read-only folder only costs the next run the hashing again)."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        staged = path.with_name(f".{path.name}.{os.getpid()}")
        staged.write_text(json.dumps(content))
        os.replace(staged, path)
    except OSError:
        pass


def on_compile(listener):
    """Call ``listener(event, name, seconds)`` around every kernel numba compiles (a
    cache miss: the first run after an install, an upgrade or an edit; not a cache
    load). ``event`` is ``"start"`` or ``"done"``, ``name`` the kernel's qualified
    name, ``seconds`` its compile time (0 at start). Nested compiles (a kernel's
    callees) are reported too. Returns ``listener``; see :func:`remove_compile_listener`.
    """
    with _LOCK:
        _listeners.append(listener)
    return listener


def remove_compile_listener(listener) -> None:
    """Stop telling ``listener`` (:func:`on_compile`) of compiles."""
    with _LOCK:
        if listener in _listeners:
            _listeners.remove(listener)


def _forward_compile_events(numba) -> None:
    """Tell the :func:`on_compile` listeners of numba's ``numba:compile`` events."""
    from numba.core import event

    class Forward(event.Listener):
        def __init__(self):
            self.started = {}

        def on_start(self, ev):
            name = _name(ev)
            self.started[name] = time.perf_counter()
            for listener in list(_listeners):
                listener("start", name, 0.0)

        def on_end(self, ev):
            name = _name(ev)
            seconds = time.perf_counter() - self.started.pop(name, time.perf_counter())
            for listener in list(_listeners):
                listener("done", name, seconds)

    event.register("numba:compile", Forward())


def _name(ev) -> str:
    function = getattr((ev.data or {}).get("dispatcher"), "py_func", None)
    return "?" if function is None else f"{function.__module__}.{function.__qualname__}"
