"""Test-wide settings."""

import os

# One BLAS thread: on this 2-core machine OpenBLAS threads oversubscribe the
# cores under pytest and made scipy's Delaunay.transform 20-100x slower.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

# The calibrated length map caches its table under $AIRMAT_CACHE: never the user's ~/.cache in tests.
import tempfile  # noqa: E402

os.environ["AIRMAT_CACHE"] = tempfile.mkdtemp(prefix="airmat-test-cache-")
