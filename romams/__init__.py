"""romams: the service layer around romams_core (settings, persistence, CLI, plots)."""

import os

# The core's dense linear algebra works on small matrices (tens to hundreds of rows), where a
# multi-threaded BLAS is several times slower than one thread, and the service runs one process per
# core anyway. Set before numpy is first imported; an explicit environment setting wins.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

__version__ = "0.1.0"
