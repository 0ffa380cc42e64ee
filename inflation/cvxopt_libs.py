"""cvxopt, imported with its bundled OpenBLAS told which kernels to use, and the libraries its wheel bundles.

cvxopt's wheel (1.3.x) bundles OpenBLAS 0.3.15, whose run-time CPU
detection predates recent Xeons: on this project's Sapphire/Emerald Rapids
machines it falls back to its Prescott (SSE3) kernels, and the dense
supernode updates of the factorization run about 3.8x slower than with the
AVX-512 ones (3.2 s against 0.83 s, large mattress at 20 mm).
:func:`openblas_coretype` picks the kernel family from the CPU's flags, and
it is handed to that OpenBLAS (``OPENBLAS_CORETYPE``, its documented
override) while cvxopt loads; a value the user has set wins.

:func:`import_cvxopt` is called by the first factorization
(:class:`airmat.inflation.cholesky.ShiftedCholesky`), not at import: importing
the solver stays cheap. :func:`cvxopt_bundled_library` hands out the libraries
cvxopt has loaded (its libcholmod for :mod:`airmat.inflation.cholmod_block`).
"""

from __future__ import annotations

import ctypes
import functools
import os
import sys
from pathlib import Path

__all__ = ["openblas_coretype", "import_cvxopt", "cvxopt_bundled_library", "cvxopt_blas_kernels"]


def openblas_coretype(flags: set[str] | None = None) -> str | None:
    """The OpenBLAS kernel family (``OPENBLAS_CORETYPE``) for this CPU, or None to let OpenBLAS choose.

    Parameters
    ----------
    flags : set of str, optional
        CPU feature flags as in ``/proc/cpuinfo`` (default: read from there;
        no file, as off Linux: None).

    Returns
    -------
    str or None
        ``"SkylakeX"`` with AVX-512 (F, CD, BW, DQ, VL), ``"Haswell"`` with
        AVX2 and FMA, else None.

    Examples
    --------
    >>> openblas_coretype({"avx", "avx2", "fma"})
    'Haswell'
    >>> openblas_coretype({"sse2"}) is None
    True
    """
    if flags is None:
        try:
            text = Path("/proc/cpuinfo").read_text()
        except OSError:
            return None
        line = next((ln for ln in text.splitlines() if ln.startswith("flags")), "")
        flags = set(line.partition(":")[2].split())
    if {"avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl"} <= flags:
        return "SkylakeX"
    if {"avx2", "fma"} <= flags:
        return "Haswell"
    return None


@functools.cache
def import_cvxopt():
    """Import cvxopt with its OpenBLAS told which kernels to use (see the module docstring).

    Called by the first factorization, not at import: importing the solver stays cheap.
    """
    coretype = None if "cvxopt" in sys.modules or "OPENBLAS_CORETYPE" in os.environ else openblas_coretype()
    if coretype is not None:
        os.environ["OPENBLAS_CORETYPE"] = coretype      # read once, when the library loads
    try:
        from cvxopt import cholmod, matrix, spmatrix
    finally:
        if coretype is not None:
            del os.environ["OPENBLAS_CORETYPE"]         # other OpenBLAS builds detect their CPU themselves
    return cholmod, matrix, spmatrix


def cvxopt_bundled_library(name: str) -> ctypes.CDLL | None:
    """One of the shared libraries cvxopt's wheel bundles (``"openblas"``, ``"cholmod"``), loaded
    by cvxopt (with the kernel family chosen above): the same handle; None without exactly one."""
    import glob

    import_cvxopt()
    import cvxopt

    libs = glob.glob(os.path.join(os.path.dirname(cvxopt.__file__), os.pardir, "cvxopt.libs", f"lib{name}*"))
    return ctypes.CDLL(libs[0]) if len(libs) == 1 else None


def cvxopt_blas_kernels() -> str | None:
    """The kernel family cvxopt's bundled OpenBLAS runs (e.g. ``"SkylakeX"``), or None without one."""
    lib = cvxopt_bundled_library("openblas")
    if lib is None:
        return None
    lib.openblas_get_corename.restype = ctypes.c_char_p
    return lib.openblas_get_corename().decode()
