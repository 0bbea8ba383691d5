"""Build hook: a wheel carries its numerical kernels compiled (the first run is quick).

``pip install .`` (or ``python -m build``) runs ``python -m inins.commands.warmup``
on the built package before it is packed: numba's on-disk cache of every kernel
and the kernel library are written next to the modules in the wheel, compiled for
the CPU of the building machine by the numba and numpy of the build environment.
A first run on that machine then loads them instead of compiling (20-90 s). Where
they do not fit (another CPU, other numba or numpy versions installed), the
kernels compile on first use, with a notice: correct, only slower to start.
``ININS_BUILD_KERNELS=0`` skips the step; editable installs skip it (``make
kernels`` compiles in the source tree).

Everything else about the package is in ``pyproject.toml``.
"""

import os
import subprocess
import sys

from setuptools import setup
from setuptools.command.build_py import build_py


def warmup_environment(build_lib, environ):
    """The warm-up's environment: the package from the build tree, pip's isolated build
    environment kept (its sitecustomize on ``PYTHONPATH`` puts the build requirements,
    numpy and numba among them, on the path), the kernels written into the build tree
    (not to a cache folder the environment names)."""
    env = {k: v for k, v in environ.items() if k not in ("NUMBA_CACHE_DIR", "ININS_KERNEL_DIR")}
    env["PYTHONPATH"] = os.pathsep.join(p for p in (build_lib, environ.get("PYTHONPATH")) if p)
    return env


class BuildPyWithKernels(build_py):
    """``build_py``, then the kernels compiled into the build tree."""

    def run(self):
        super().run()
        if getattr(self, "editable_mode", False) or os.environ.get("ININS_BUILD_KERNELS") == "0":
            return
        build_lib = os.path.abspath(self.build_lib)
        env = warmup_environment(build_lib, os.environ)
        print("inins: compiling the numerical kernels into the wheel (about a minute) ...")
        done = subprocess.run(
            [sys.executable, "-m", "inins.commands.warmup"], cwd=build_lib, env=env, check=False
        )
        if done.returncode != 0:
            print(
                "inins: the kernels were not compiled into the wheel; they compile on "
                "first use instead",
                file=sys.stderr,
            )


setup(cmdclass={"build_py": BuildPyWithKernels})
