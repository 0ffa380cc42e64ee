"""Test-wide settings."""

import os

# One BLAS thread: on this 2-core machine OpenBLAS threads oversubscribe the
# cores under pytest and made scipy's Delaunay.transform 20-100x slower.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

# The calibrated length map caches its table under $AIRMAT_CACHE: never the user's ~/.cache in tests.
import tempfile  # noqa: E402

os.environ["AIRMAT_CACHE"] = tempfile.mkdtemp(prefix="airmat-test-cache-")

import pytest  # noqa: E402


@pytest.fixture(name="wrote")
def _wrote_fixture():
    """The files a command's summary names on its one 'wrote ... to OUT' line (a set of names)."""

    def files(text: str, out) -> set:
        line = [ln.strip() for ln in text.splitlines() if ln.strip().startswith("wrote ")]
        assert len(line) == 1 and line[0].endswith(f" to {out}"), text
        return set(line[0][len("wrote "):-len(f" to {out}")].split(", "))

    return files
