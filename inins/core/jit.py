"""Compiled kernels, paying for numba only when one is compiled.

Kernel modules decorate with :func:`njit` (the options of ``numba.njit``) instead
of importing numba. Until a kernel is called nothing of numba is loaded: importing
numba and setting up its compiler costs about 0.5 s per process, more than a
short run computes.

A kernel marked ``aot=True`` is also compiled ahead of time into one extension
module, the *kernel library*, which ``python -m inins.commands.warmup`` builds at
install (numba's ``pycc``), holding every specialisation the warm-up compiled (the
argument types the commands pass). A call whose arguments have exactly the types
of one of them runs the library's copy without loading numba; any other call, or
any call once :func:`activate` has run, goes through numba's dispatcher (its
on-disk cache, or a compile). The library copy is compiled from the same source
by the same compiler, for this processor (its instruction-set extensions, as
numba compiles for it; the library records the processor and is used only on
one that reads the same), and gives bit-identical results (a test compares both
on whole runs). Its functions release the GIL while they run, so a run can
compute its truth in a second thread (:mod:`inins.core.prefetch`). It runs as
fast as numba's copy, so a process uses it for every call and never loads numba
for a command's usual path. Where the processor cannot be read (no
``/proc/cpuinfo``) the library is built for a generic CPU of the architecture and
takes 1.1-1.6 times as long; then a process runs each kernel's first
:data:`LIBRARY_ROWS` rows through it and loads numba for the rest (a budget per
kernel: a run calls several over the same samples). A Dask worker, whose threads
share one process, loads numba at once.

Cache keys. numba stamps its on-disk cache of a kernel with the hash of the
kernel's own file, so a kernel that calls or inlines one from another module
would keep running the old callee after an edit (or an upgrade) of that module
only. Here every ``inins`` kernel's cache entry, and the library, are stamped
with one hash of all the kernel sources (:func:`kernel_sources`: the kernel
modules and every ``inins`` module they import): a change anywhere in them
recompiles every kernel, once; a change elsewhere (commands, CLI, I/O) keeps them.

The library sits next to the package's bytecode (``inins/__pycache__``), under
``$NUMBA_CACHE_DIR/inins`` when that is set, or in ``$ININS_KERNEL_DIR``. It is
used only while the Python, numpy and numba it was built with are installed and
the kernel sources hash as they did at the build; otherwise calls go to numba,
silently and correctly. (A run compares the sources' sizes and modification times
with the build's first, as Python's bytecode cache does, and hashes them only when
those differ; the check costs a short run no ``hashlib``, ``sysconfig`` or package
metadata.) Builds are serialised by a lock file; each build writes a new file and
then the manifest naming it, so a reader sees one build whole.

numba marks ``pycc`` for deprecation (0.57) without a removal date; it exists in
every release ``pyproject.toml`` allows (0.59-0.68, upper bound ``<0.69``). Where
it is missing the warm-up says so and every call goes to numba (correct, 0.5-1 s
slower to start a short run).

A compile (not a cache load) is reported to the :func:`on_compile` listeners:
the command line says what it prepares while a first run compiles.
"""

import contextlib
import functools
import importlib.machinery
import importlib.util
import json
import os
import re
import sys
import threading
from pathlib import Path

import numpy as np

__all__ = [
    "Kernel",
    "activate",
    "build_library",
    "kernel_sources",
    "library_dir",
    "library_status",
    "njit",
    "on_compile",
    "source_digest",
]

LIBRARY = "_inins_kernels"
"""Module name of the kernel library (an extension module)."""
_PACKAGE = Path(__file__).resolve().parents[1]

_LOCK = threading.RLock()
_PENDING = []
"""Kernels made before numba was loaded; given their dispatchers by :func:`activate`."""
_AOT = {}
"""Qualified name -> kernel (or dispatcher, once activated) for the library."""
_numba = None
_library = None
LIBRARY_ROWS = 1_000_000
"""Rows (the longest first axis among a call's array arguments: samples, for the
table, sensor and strapdown kernels) a process runs through a generic kernel library
(one not compiled for this processor) before it loads numba: 0.1-0.2 s of work,
against numba's 0.5 s start-up."""
_library_rows = {}
"""Qualified name -> rows run through the library's copy by this process."""
_source_digest = None
"""Hash of the kernel sources (:func:`kernel_sources`), computed once."""
_compile_listeners = []
"""Callables told of every kernel numba compiles (not loads): :func:`on_compile`."""


def njit(function=None, *, aot=False, **options):
    """Decorator like ``numba.njit(**options)``, compiling on first use.

    ``aot=True`` also puts the kernel into the kernel library (module docstring);
    its qualified name (module and function) must be unique among such kernels.
    Usable as ``@njit``, ``@njit(**options)`` or ``njit(**options)(function)``.
    """

    def decorate(fn):
        with _LOCK:
            made = Kernel(fn, options) if _numba is None else _numba.njit(**options)(fn)
            if _numba is None:
                _PENDING.append(made)
            if aot:
                _AOT[_qualname(fn)] = made
        return made

    return decorate if function is None else decorate(function)


def _qualname(fn):
    return f"{fn.__module__}.{fn.__qualname__}"


def _within_budget(qualname, args):
    """Count the call's rows for kernel ``qualname``; True while that kernel is within
    :data:`LIBRARY_ROWS` in this process.

    The budget is each kernel's own: a run calls several kernels over the same
    samples (trajectory, sensor errors, pulses, strapdown), and a budget shared
    among them would load numba for a run no longer than any one kernel's limit.
    """
    rows = max((a.shape[0] for a in args if isinstance(a, np.ndarray) and a.ndim), default=0)
    with _LOCK:
        total = _library_rows.get(qualname, 0) + rows
        _library_rows[qualname] = total
    return total <= LIBRARY_ROWS


class Kernel:
    """A function numba compiles on first use, or runs from the kernel library.

    Calls take the library's copy when the arguments match the types it was built
    for, numba is not loaded and the process is within :data:`LIBRARY_ROWS`; else
    the dispatcher. Attributes other than
    ``py_func`` (``signatures``, ``inspect_types``, ...) are the dispatcher's and
    load numba.
    """

    _dispatcher = None

    def __init__(self, function, options):
        functools.update_wrapper(self, function)
        self.py_func = function
        self._options = options

    def __call__(self, *args):
        if self._dispatcher is None:
            name = _qualname(self.py_func)
            compiled = _compiled(name)
            function = None if compiled is None else compiled.function_for(args)
            if function is not None and (compiled.native or _within_budget(name, args)):
                if threading.get_ident() != _MAIN_THREAD:
                    return function(*args)
                return _in_main_thread(function, args)
            activate()
        return self._dispatcher(*args)

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        activate()
        return getattr(self._dispatcher, name)

    def __repr__(self):
        return f"<inins kernel {_qualname(self.py_func)}>"


_MAIN_THREAD = threading.main_thread().ident
_deferring = False
"""The main thread is running a library function (:func:`_in_main_thread`)."""
_deferred = False
"""An interrupt arrived meanwhile (:func:`interrupt_deferred`)."""


def _in_main_thread(function, args):
    """Call a library function in the main thread, raising KeyboardInterrupt after it
    if a signal handler deferred one meanwhile (:func:`interrupt_deferred`)."""
    global _deferring, _deferred
    _deferring = True
    try:
        result = function(*args)
    finally:
        _deferring = False
    if _deferred:
        _deferred = False
        raise KeyboardInterrupt
    return result


def interrupt_deferred() -> bool:
    """For a signal handler that raises KeyboardInterrupt: True if it must not raise
    now, because the main thread is inside a kernel-library function; the interrupt
    is then raised when that function returns.

    A library function can call back into Python: its first BLAS product imports
    ``scipy.linalg.cython_blas`` to find the routine (numba's helper library, with the
    GIL taken again), and a KeyboardInterrupt raised in that import makes the lookup
    fail where nothing can be raised, which numba ends with a fatal error (the process
    aborts). Deferred, the import completes and the kernel with it.
    """
    global _deferred
    if _deferring:
        _deferred = True
        return True
    return False


def activate():
    """Load numba and give every kernel its dispatcher; return the numba module.

    Module globals of ``inins`` that hold a :class:`Kernel` are replaced by its
    dispatcher, so that numba, compiling one kernel, sees the others as its own
    (and inlines those marked ``inline="always"``). Idempotent and thread-safe.
    """
    global _numba
    if _numba is not None:
        return _numba
    with _LOCK:
        if _numba is not None:
            return _numba
        import numba

        _key_numba_cache()
        _report_compiles()
        for kernel in _PENDING:
            kernel._dispatcher = numba.njit(**kernel._options)(kernel.py_func)
        for name, module in list(sys.modules.items()):
            if name == "inins" or name.startswith("inins."):
                space = vars(module)
                for key, value in list(space.items()):
                    if isinstance(value, Kernel):
                        space[key] = value._dispatcher
        for key, value in list(_AOT.items()):
            if isinstance(value, Kernel):
                _AOT[key] = value._dispatcher
        _PENDING.clear()
        _numba = numba
    return numba


def kernel_sources():
    """Package-relative paths of every source compiled code can depend on.

    The kernel modules (the modules that use :func:`njit`) and, transitively,
    every module of ``inins`` they import: the kernels a kernel calls or inlines
    and the module constants numba freezes into the machine code. Found by reading
    the sources (``import`` statements), so the set does not depend on which
    modules a process happens to have imported.
    """
    found = set()
    todo = [
        path
        for path in sorted(_PACKAGE.rglob("*.py"))
        if "__pycache__" not in path.parts and "njit" in path.read_text(encoding="utf-8")
    ]
    while todo:
        path = todo.pop()
        if path in found:
            continue
        found.add(path)
        todo.extend(_imported_files(path))
    found.discard(Path(__file__).resolve())  # the machinery: options are in the modules
    return sorted(p.relative_to(_PACKAGE).as_posix() for p in found)


def _module_file(dotted):
    """Source of module ``dotted`` (``inins....``) in this package, or None."""
    parts = dotted.split(".")
    if parts[0] != _PACKAGE.name:
        return None
    base = _PACKAGE.joinpath(*parts[1:])
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


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
            found = _module_file(".".join(parts[:i]))
            if found is not None:
                files.append(found)
    return files


def source_digest():
    """One hash of the sources of :func:`kernel_sources` (computed once a process)."""
    global _source_digest
    if _source_digest is None:
        import hashlib

        digest = hashlib.sha256()
        for name, value in _source_key(kernel_sources()).items():
            digest.update(f"{name}={value}\n".encode())
        _source_digest = digest.hexdigest()
    return _source_digest


def _key_numba_cache():
    """Make numba's on-disk cache of an ``inins`` kernel valid only for the sources
    it was compiled from: all of :func:`kernel_sources`, not the kernel's own file.

    numba stamps a cache entry with the hash of the file that defines the kernel,
    so a kernel that calls or inlines one from another module would keep running
    the old callee after an edit of that module (or an upgrade that changes only
    the callee). A locator placed before numba's own ones takes the cache folder
    from them and gives the stamp :func:`source_digest` instead.
    """
    from numba.core import caching

    if any(getattr(c, "_inins", False) for c in caching.CacheImpl._locator_classes):
        return
    standard = list(caching.CacheImpl._locator_classes)

    class PackageSourcesLocator(caching._CacheLocator):
        _inins = True

        def __init__(self, inner):
            self._inner = inner

        def ensure_cache_path(self):
            self._inner.ensure_cache_path()

        def get_cache_path(self):
            return self._inner.get_cache_path()

        def get_source_stamp(self):
            return ("inins kernel sources", source_digest())

        def get_disambiguator(self):
            return self._inner.get_disambiguator()

        @classmethod
        def from_function(cls, py_func, py_file):
            try:
                Path(py_file).resolve().relative_to(_PACKAGE)
            except ValueError:
                return None  # not ours: numba's own locators decide
            for locator_class in standard:
                inner = locator_class.from_function(py_func, py_file)
                if inner is not None:
                    return cls(inner)
            return None

    caching.CacheImpl._locator_classes = [PackageSourcesLocator, *standard]


def on_compile(listener):
    """Call ``listener(event, name, seconds)`` around every kernel numba compiles
    (a cache miss: the first run after an install, an upgrade or an edit; not a
    cache load). ``event`` is ``"start"`` or ``"done"``, ``name`` the kernel's
    qualified name, ``seconds`` its compile time (0 at start). Nested compiles (a
    kernel's callees) are reported too. Returns ``listener``; see
    :func:`remove_compile_listener`."""
    with _LOCK:
        _compile_listeners.append(listener)
    return listener


def remove_compile_listener(listener) -> None:
    """Stop telling ``listener`` (:func:`on_compile`) of compiles."""
    with _LOCK, contextlib.suppress(ValueError):
        _compile_listeners.remove(listener)


def _report_compiles():
    """Forward numba's compile events to the :func:`on_compile` listeners."""
    import time

    from numba.core import event

    class Forward(event.Listener):
        def __init__(self):
            self.started = {}

        def _name(self, ev):
            dispatcher = (ev.data or {}).get("dispatcher")
            function = getattr(dispatcher, "py_func", None)
            return _qualname(function) if function is not None else "?"

        def on_start(self, ev):
            name = self._name(ev)
            self.started[name] = time.perf_counter()
            for listener in list(_compile_listeners):
                listener("start", name, 0.0)

        def on_end(self, ev):
            name = self._name(ev)
            seconds = time.perf_counter() - self.started.pop(name, time.perf_counter())
            for listener in list(_compile_listeners):
                listener("done", name, seconds)

    event.register("numba:compile", Forward())


def library_dir():
    """Directory of the kernel library (module docstring)."""
    if os.environ.get("ININS_KERNEL_DIR"):
        return Path(os.environ["ININS_KERNEL_DIR"])
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"]) / "inins"
    return _PACKAGE / "__pycache__"


def _manifest_path(directory):
    return Path(directory) / f"{LIBRARY}.json"


def _library_file(directory, manifest):
    """The extension module a manifest names (in ``directory``)."""
    name = Path(str(manifest.get("library", ""))).name
    return Path(directory) / name if name else None


def _source_key(files):
    """{file: sha256} of kernel sources, relative to the package; None if one is gone."""
    import hashlib

    key = {}
    for name in sorted(files):
        path = _PACKAGE / name
        if not path.is_file():
            return None
        key[name] = hashlib.sha256(path.read_bytes()).hexdigest()
    return key


def _source_stats(files):
    """{file: [size, mtime_ns]} of kernel sources; None if one is gone."""
    stats = {}
    for name in sorted(files):
        try:
            st = (_PACKAGE / name).stat()
        except OSError:
            return None
        stats[name] = [st.st_size, st.st_mtime_ns]
    return stats


def _sources_unchanged(manifest):
    """True while the kernel sources are those the library was built from.

    The manifest's ``sources`` holds each file's sha256; its ``stats`` (size and
    modification time in ns, as Python's own bytecode cache checks a source) let a
    run skip reading and hashing the files while none was touched. A file whose
    stat changed is hashed: the library stays usable if its content did not.
    """
    sources = manifest.get("sources")
    if not isinstance(sources, dict):
        return False
    stats = manifest.get("stats")
    if isinstance(stats, dict) and stats.keys() == sources.keys():
        if _source_stats(sources) == stats:
            return True
    return sources == _source_key(sources)


def _ext_suffix():
    """File suffix of extension modules of this Python (``sysconfig``'s EXT_SUFFIX:
    ``.cpython-311-x86_64-linux-gnu.so``) without loading ``sysconfig``."""
    return importlib.machinery.EXTENSION_SUFFIXES[0]


def _numba_version():
    """The installed numba's version, without importing numba (or reading its
    metadata with ``importlib.metadata``, which costs a run about 10 ms): the name
    of its ``numba-VERSION.dist-info`` folder beside the package, else the
    metadata."""
    spec = importlib.util.find_spec("numba")
    if spec is not None and spec.origin:
        site = Path(spec.origin).parent.parent
        found = [p.name for p in site.glob("numba-*.dist-info")]
        if len(found) == 1:
            return found[0][len("numba-") : -len(".dist-info")]
    from importlib import metadata

    return metadata.version("numba")


def _versions():
    return {"numpy": np.__version__, "numba": _numba_version()}


def library_status(directory=None):
    """Why the kernel library is (not) used: ``(usable, reason)``."""
    usable, reason, _ = _status(Path(directory) if directory else library_dir())
    return usable, reason


def _status(directory):
    """``(usable, reason, manifest)`` of the kernel library in ``directory``."""
    manifest_path = _manifest_path(directory)
    try:
        manifest = json.loads(manifest_path.read_text())
    except FileNotFoundError:
        return False, f"no kernel library in {directory}", None
    except (OSError, ValueError) as exc:
        return False, f"{manifest_path}: unreadable ({exc})", None
    shared = _library_file(directory, manifest) if isinstance(manifest, dict) else None
    if shared is None or not shared.is_file():
        return False, f"no kernel library in {directory}", None
    if manifest.get("format") != _FORMAT:
        return False, f"a library of another layout ({manifest.get('format')})", None
    if manifest.get("python") != _ext_suffix():
        return False, f"built for another Python ({manifest.get('python')})", None
    if manifest.get("versions") != _versions():
        return False, f"built for {manifest.get('versions')}, installed {_versions()}", None
    cpu = manifest.get("cpu")
    if cpu is not None and cpu != _host_cpu():
        return False, f"built for another processor ({cpu.get('model')})", None
    if not _sources_unchanged(manifest):
        return False, "a kernel module changed since the library was built", None
    return True, f"{len(manifest['exports'])} kernels in {shared}", manifest


class _Compiled:
    """A kernel's functions in the library, one per specialisation, with the argument
    types each takes."""

    __slots__ = ("_chosen", "native", "variants")

    def __init__(self, variants, native):
        self.variants = variants
        """``[(function, types), ...]``."""
        self.native = native
        """Compiled for this processor (as fast as numba's copy: no row budget)."""
        self._chosen = {}
        """:func:`_key` of the arguments -> the function for them (or None)."""

    def function_for(self, args):
        """The library function compiled for the types of ``args``, else None.

        The choice is remembered by a cheap key of the arguments (:func:`_key`), so a
        kernel called once per epoch with fifty arguments pays a microsecond or so per
        call, not the full :func:`_describe` of each (``dtype.name`` alone costs 1.5 us).
        """
        key = tuple(map(_key, args))
        try:
            return self._chosen[key]
        except KeyError:
            pass
        described = [_describe(a) for a in args]
        found = None
        for function, types in self.variants:
            if described == types:
                found = function
                break
        self._chosen[key] = found
        return found


def _compiled(qualname):
    global _library
    if _library is None:
        with _LOCK:
            if _library is None:
                _library = _load()
    return _library.get(qualname)


def _load():
    """The kernel library's functions by qualified name, or {} if it is not usable."""
    directory = library_dir()
    usable, _, manifest = _status(directory)
    if not usable:
        return {}
    shared = _library_file(directory, manifest)
    loader = importlib.machinery.ExtensionFileLoader(LIBRARY, str(shared))
    spec = importlib.util.spec_from_file_location(LIBRARY, shared, loader=loader)
    try:
        module = importlib.util.module_from_spec(spec)
        loader.exec_module(module)
    except (ImportError, OSError):  # replaced by a newer build meanwhile: numba serves
        return {}
    native = manifest.get("cpu") is not None
    return {
        name: _Compiled([(getattr(module, e["export"]), e["args"]) for e in entries], native)
        for name, entries in manifest["exports"].items()
    }


_ARRAY_FLAGS = 0x1 | 0x2 | 0x100 | 0x400
"""C-contiguous, Fortran-contiguous, aligned and writeable: the bits of ``flags.num``
that decide an array's numba type besides its dtype and dimensions."""


def _key(value):
    """A hashable key that decides :func:`_describe` of ``value`` (equal keys, equal
    descriptions), at a fraction of its cost: for an array its dtype, dimensions and
    flag bits, for a tuple the keys of its items, else the type."""
    if isinstance(value, np.ndarray):
        return (value.dtype, value.ndim, value.flags.num & _ARRAY_FLAGS)
    if type(value) is tuple:
        return ("tuple", *map(_key, value))
    return type(value)


def _describe(value):
    """The argument type of ``value`` as numba's dispatcher would see it (JSON form)."""
    if isinstance(value, np.ndarray):
        flags = value.flags
        layout = "C" if flags.c_contiguous else "F" if flags.f_contiguous else "A"
        return ["array", value.dtype.name, value.ndim, layout, flags.writeable, flags.aligned]
    if isinstance(value, (bool, np.bool_)):
        return "bool"
    if isinstance(value, int):
        return "int64"
    if isinstance(value, float):  # np.float64 included
        return "float64"
    if isinstance(value, np.generic):
        return value.dtype.name
    if isinstance(value, tuple):
        return ["tuple", [_describe(v) for v in value]]
    if isinstance(value, np.random.Generator):
        return "generator"
    return None


def _describe_type(ty):
    """The JSON form of a numba argument type, as :func:`_describe` gives it."""
    from numba.core import types

    if isinstance(ty, types.Array):
        return ["array", str(ty.dtype), ty.ndim, ty.layout, ty.mutable, ty.aligned]
    if isinstance(ty, types.Boolean):
        return "bool"
    if isinstance(ty, (types.Integer, types.Float)) and not isinstance(ty, types.Literal):
        return str(ty)
    if isinstance(ty, types.BaseTuple):
        return ["tuple", [_describe_type(t) for t in ty.types]]
    if isinstance(ty, types.NumPyRandomGeneratorType):
        return "generator"
    raise TypeError(f"no kernel library form for argument type {ty}")


def _forwarder(target, n_args):
    """A function of ``n_args`` arguments returning ``target(*args)``.

    The library exports this wrapper, so that the kernel itself is compiled with
    its own options (error model, inlining) as numba's dispatcher compiles it.
    """
    names = ", ".join(f"a{i}" for i in range(n_args))
    space = {"target": target}
    exec(f"def forward({names}):\n    return target({names})\n", space)
    return space["forward"]


_FORMAT = 2
"""Layout of the manifest (2: every specialisation of a kernel, a list per kernel)."""


def build_library(directory=None):
    """Compile the ``aot`` kernels into the kernel library; return its path.

    The library holds every specialisation numba has compiled of each kernel in this
    process (run the modules' ``warm_up()`` first: the argument types the commands
    pass; a kernel that another calls may have a second one, for that caller's
    types), each as its own function. One build at a time per folder (a lock file); the
    extension module gets a new name each build and the manifest naming it is
    replaced last, so a reader sees the old library or the new one, never half
    of one; older builds are then removed.
    """
    import tempfile

    activate()
    from numba.pycc import CC

    directory = Path(directory) if directory else library_dir()
    directory.mkdir(parents=True, exist_ok=True)
    suffix = _ext_suffix()
    with _folder_lock(directory):
        exports = {}
        with tempfile.TemporaryDirectory(dir=directory) as work:
            cc = CC(LIBRARY)
            cc.output_dir = work
            cc.verbose = False
            for name, dispatcher in sorted(_AOT.items()):
                signatures = dispatcher.nopython_signatures
                if not signatures:
                    raise RuntimeError(f"{name}: never compiled (call its module's warm_up())")
                exports[name] = []
                for i, signature in enumerate(signatures):
                    try:
                        args = [_describe_type(t) for t in signature.args]
                    except TypeError:  # a callee's types no Python call has: not needed
                        continue
                    export = f"{name.replace('.', '__')}__{i}"
                    cc.export(export, signature)(_forwarder(dispatcher, len(signature.args)))
                    exports[name].append({"export": export, "args": args})
            cpu = _host_cpu()
            with _compiled_for_this_cpu(cc, cpu is not None) as host, _without_the_gil() as nogil:
                cc.compile()
            cpu = cpu if host else None  # a generic build runs on any of the architecture
            sources = kernel_sources()
            shared = directory / f"{LIBRARY}-{source_digest()[:12]}-{os.getpid()}{suffix}"
            manifest = {
                "format": _FORMAT,
                "library": shared.name,
                "python": suffix,
                "versions": _versions(),
                "cpu": cpu,
                "nogil": nogil,
                "sources": _source_key(sources),
                "stats": _source_stats(sources),
                "exports": exports,
            }
            staged = Path(work) / "manifest.json"
            staged.write_text(json.dumps(manifest, indent=1))
            os.replace(Path(work) / f"{LIBRARY}{suffix}", shared)
            os.replace(staged, _manifest_path(directory))
        for old in directory.glob(f"{LIBRARY}*{suffix}*"):  # earlier builds and layouts
            if old != shared:
                old.unlink(missing_ok=True)
    return shared


_CPU_FIELDS = {  # /proc/cpuinfo key -> manifest key: what decides the instructions usable
    "vendor_id": "vendor",
    "model name": "model",
    "flags": "flags",  # x86
    "CPU implementer": "vendor",
    "CPU part": "model",
    "Features": "flags",  # ARM
}


def _host_cpu():
    """This processor as ``/proc/cpuinfo`` describes its first core (vendor, model name,
    instruction-set flags), or None where that file is missing or says no flags.

    The kernel library is compiled for this processor (its instruction-set extensions,
    as numba compiles for it) and used only on one that reads the same: the first
    block of the file, a few kilobytes, costs a run well under a millisecond, where
    asking LLVM (``llvmlite.binding``) would cost 30 ms.
    """
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            block = f.read(16384).split("\n\n", 1)[0]
    except OSError:
        return None
    cpu = {}
    for line in block.splitlines():
        key, sep, value = line.partition(":")
        name = _CPU_FIELDS.get(key.strip())
        if sep and name is not None:
            cpu[name] = " ".join(value.split())
    return cpu if cpu.get("flags") else None


@contextlib.contextmanager
def _compiled_for_this_cpu(cc, host):
    """Compile ``cc`` (a ``numba.pycc.CC``) for this processor when ``host``, else for
    the generic CPU of the architecture (pycc's default); yields whether it is for
    this processor.

    pycc takes a CPU name only; given ``"host"`` it would enable every feature of the
    model LLVM names, and a virtual machine may hide some of them. So the target's
    features are set, for the build, to the ones this processor reports, as numba's
    own compiler sets them for every kernel it compiles at run time.
    """
    from numba.core import codegen

    aot = getattr(codegen, "AOTCPUCodegen", None)
    features = getattr(codegen.CPUCodegen, "_get_host_cpu_features", None)
    if not host or aot is None or features is None or "_customize_tm_features" not in vars(aot):
        yield False
        return
    original = aot._customize_tm_features
    cc.target_cpu = "host"
    aot._customize_tm_features = features
    try:
        yield True
    finally:
        aot._customize_tm_features = original


@contextlib.contextmanager
def _without_the_gil():
    """Make the library's functions release the GIL while they run, as numba's
    dispatcher does for a ``nogil`` kernel; yields whether they will.

    pycc compiles every export with one set of default compiler flags, whose
    ``release_gil`` is off; for the build they are replaced by the same flags with
    it on. The kernels are nopython code (no Python object is touched once the
    arguments are unboxed), so every one may run beside other threads: a run
    computes its truth in one thread while the filter runs in another
    (:func:`inins.core.prefetch.ahead`).
    """
    from numba.pycc import compiler

    flags = getattr(compiler, "Flags", None)
    if flags is None or "release_gil" not in getattr(flags, "options", {}):
        yield False
        return

    class Released(flags):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            self.release_gil = True

    compiler.Flags = Released
    try:
        yield True
    finally:
        compiler.Flags = flags


class _folder_lock:
    """An exclusive lock on ``directory/.LIBRARY.lock`` (waits for another build)."""

    def __init__(self, directory):
        self.path = Path(directory) / f".{LIBRARY}.lock"
        self.handle = None

    def __enter__(self):
        import fcntl

        self.handle = self.path.open("a")
        fcntl.flock(self.handle, fcntl.LOCK_EX)
        return self

    def __exit__(self, *exc):
        self.handle.close()  # releases the lock
        return False
