"""Compiled kernels, paying for numba only when one is compiled.

Kernel modules decorate with :func:`njit` (the options of ``numba.njit``) instead
of importing numba. Until a kernel is called nothing of numba is loaded: importing
numba and setting up its compiler costs about 0.5 s per process, more than a
short run computes.

A kernel marked ``aot=True`` is also compiled ahead of time into one extension
module, the *kernel library*, which ``python -m inins.commands.warmup`` builds at
install (numba's ``pycc``, for the argument types the warm-up passed). A call
whose arguments have exactly those types runs the library's copy without loading
numba; any other call, or any call once :func:`activate` has run, goes through
numba's dispatcher (its on-disk cache, or a compile). The library copy, compiled
from the same source by the same compiler for a generic CPU of the architecture,
gives bit-identical results (a test compares both on a whole run). It holds
the GIL while it runs, where the dispatcher releases it for ``nogil`` kernels, and
takes 1.1-1.6 times as long as numba's copy compiled for this CPU: it is for short
runs, where numba's start-up would dominate. So a process takes the library for its
first :data:`LIBRARY_ROWS` rows of work and loads numba for the rest (a sweep worker,
which lives for many runs, loads numba at once).

The library sits next to the package's bytecode (``inins/__pycache__``), under
``$NUMBA_CACHE_DIR/inins`` when that is set, or in ``$ININS_KERNEL_DIR``. It is
used only while the numpy and numba versions it was built with are installed and
the source of every kernel module hashes as it did at the build; otherwise calls
fall back to numba, silently and correctly.
"""

import functools
import hashlib
import importlib.machinery
import importlib.util
import json
import os
import sys
import sysconfig
import tempfile
import threading
from importlib import metadata
from pathlib import Path

import numpy as np

__all__ = ["Kernel", "activate", "build_library", "library_dir", "library_status", "njit"]

LIBRARY = "_inins_kernels"
"""Module name of the kernel library (an extension module)."""
_PACKAGE = Path(__file__).resolve().parents[1]

_LOCK = threading.RLock()
_PENDING = []
"""Kernels made before numba was loaded; given their dispatchers by :func:`activate`."""
_AOT = {}
"""Qualified name -> kernel (or dispatcher, once activated) for the library."""
_MODULES = set()
"""Names of the modules that define kernels (their source keys the library)."""
_numba = None
_library = None
LIBRARY_ROWS = 1_000_000
"""Rows (the longest first axis among a call's array arguments: samples, for the
table, sensor and strapdown kernels) a process runs through the kernel library
before it loads numba: 0.1-0.2 s of work, against numba's 0.5 s start-up."""
_library_rows = 0
"""Qualified name -> _Compiled, loaded on first use; {} when there is none."""


def njit(function=None, *, aot=False, **options):
    """Decorator like ``numba.njit(**options)``, compiling on first use.

    ``aot=True`` also puts the kernel into the kernel library (module docstring);
    its qualified name (module and function) must be unique among such kernels.
    Usable as ``@njit``, ``@njit(**options)`` or ``njit(**options)(function)``.
    """

    def decorate(fn):
        _MODULES.add(fn.__module__)
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


def _within_budget(args):
    """Count the call's rows; True while the process is within :data:`LIBRARY_ROWS`."""
    global _library_rows
    _library_rows += max(
        (a.shape[0] for a in args if isinstance(a, np.ndarray) and a.ndim), default=0
    )
    return _library_rows <= LIBRARY_ROWS


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
            compiled = _compiled(_qualname(self.py_func))
            if compiled is not None and compiled.accepts(args) and _within_budget(args):
                return compiled.function(*args)
            activate()
        return self._dispatcher(*args)

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        activate()
        return getattr(self._dispatcher, name)

    def __repr__(self):
        return f"<inins kernel {_qualname(self.py_func)}>"


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


def library_dir():
    """Directory of the kernel library (module docstring)."""
    if os.environ.get("ININS_KERNEL_DIR"):
        return Path(os.environ["ININS_KERNEL_DIR"])
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"]) / "inins"
    return _PACKAGE / "__pycache__"


def _paths(directory):
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    return directory / f"{LIBRARY}{suffix}", directory / f"{LIBRARY}{suffix}.json"


def _source_key(files):
    """{file: sha256} of kernel sources, relative to the package; None if one is gone."""
    key = {}
    for name in sorted(files):
        path = _PACKAGE / name
        if not path.is_file():
            return None
        key[name] = hashlib.sha256(path.read_bytes()).hexdigest()
    return key


def _module_files():
    """Sources of the modules that define kernels, relative to the package."""
    return [
        Path(sys.modules[name].__file__).resolve().relative_to(_PACKAGE).as_posix()
        for name in _MODULES
    ]


def _versions():
    return {"numpy": np.__version__, "numba": metadata.version("numba")}


def library_status(directory=None):
    """Why the kernel library is (not) used: ``(usable, reason)``."""
    shared, manifest_path = _paths(Path(directory) if directory else library_dir())
    if not (shared.is_file() and manifest_path.is_file()):
        return False, f"no kernel library in {shared.parent}"
    try:
        manifest = json.loads(manifest_path.read_text())
    except (OSError, ValueError) as exc:
        return False, f"{manifest_path}: unreadable ({exc})"
    if manifest.get("versions") != _versions():
        return False, f"built for {manifest.get('versions')}, installed {_versions()}"
    if manifest.get("sources") != _source_key(manifest.get("sources", {})):
        return False, "a kernel module changed since the library was built"
    return True, f"{len(manifest['exports'])} kernels in {shared}"


class _Compiled:
    """One library function and the argument types it takes."""

    __slots__ = ("function", "types")

    def __init__(self, function, types):
        self.function, self.types = function, types

    def accepts(self, args):
        return len(args) == len(self.types) and all(
            _describe(a) == t for a, t in zip(args, self.types, strict=True)
        )


def _compiled(qualname):
    global _library
    if _library is None:
        with _LOCK:
            if _library is None:
                _library = _load()
    return _library.get(qualname)


def _load():
    """The kernel library's functions by qualified name, or {} if it is not usable."""
    usable, _ = library_status()
    if not usable:
        return {}
    shared, manifest_path = _paths(library_dir())
    manifest = json.loads(manifest_path.read_text())
    loader = importlib.machinery.ExtensionFileLoader(LIBRARY, str(shared))
    spec = importlib.util.spec_from_file_location(LIBRARY, shared, loader=loader)
    try:
        module = importlib.util.module_from_spec(spec)
        loader.exec_module(module)
    except ImportError:
        return {}
    return {
        name: _Compiled(getattr(module, entry["export"]), entry["args"])
        for name, entry in manifest["exports"].items()
    }


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


def build_library(directory=None):
    """Compile the ``aot`` kernels into the kernel library; return its path.

    Each kernel must have been called (compiled) for exactly one argument-type
    signature in this process, the one the library takes: run the modules'
    ``warm_up()`` first. Written under temporary names and renamed, so a reader
    never sees half a library.
    """
    numba = activate()
    from numba.pycc import CC

    directory = Path(directory) if directory else library_dir()
    directory.mkdir(parents=True, exist_ok=True)
    shared, manifest_path = _paths(directory)
    exports = {}
    with tempfile.TemporaryDirectory(dir=directory) as work:
        cc = CC(LIBRARY)
        cc.output_dir = work
        cc.verbose = False
        for name, dispatcher in sorted(_AOT.items()):
            signatures = dispatcher.nopython_signatures
            if len(signatures) != 1:
                raise RuntimeError(
                    f"{name}: {len(signatures)} compiled signatures, the library takes one "
                    "(call the module's warm_up() first)"
                )
            (signature,) = signatures
            export = name.replace(".", "__")
            cc.export(export, signature)(_forwarder(dispatcher, len(signature.args)))
            exports[name] = {
                "export": export,
                "args": [_describe_type(t) for t in signature.args],
            }
        cc.compile()
        built, _ = _paths(Path(work))
        manifest = {
            "versions": {"numpy": np.__version__, "numba": numba.__version__},
            "sources": _source_key(_module_files()),
            "exports": exports,
        }
        staged = Path(work) / manifest_path.name
        staged.write_text(json.dumps(manifest, indent=1))
        os.replace(built, shared)
        os.replace(staged, manifest_path)
    return shared
