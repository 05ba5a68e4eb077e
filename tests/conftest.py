"""Test-session setup shared by every test module."""

import os

# one BLAS thread: the core's matrices are small and the CI machine has 2 cores (see romams/__init__.py)
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

# OpenMDAO writes HTML reports into <script>_out/ in the working directory unless told not to
os.environ.setdefault("OPENMDAO_REPORTS", "0")
