"""Test session set-up: one BLAS thread per process.

The numerics work on small matrices (up to 26 x 26), where a multi-threaded BLAS
only adds hand-over cost; with pytest-xdist every core already runs a worker, and
on a loaded two-core machine threaded OpenBLAS made such calls 50-100 times slower.
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
