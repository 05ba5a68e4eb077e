"""Test-session setup shared by every test module."""

import os

# one BLAS thread: the core's matrices are small and the CI machine has 2 cores (see romams/__init__.py)
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
