"""CHOLMOD's solve of many right-hand sides at once, on a factor that cvxopt holds.

cvxopt's ``cholmod.solve`` calls CHOLMOD once per column of the right-hand
side, and every call streams the whole factor through memory: the adjoint
Jacobian of the refinement (:func:`check.adjoint.equilibrium_jacobian`, one
column per string) is then bound by memory bandwidth. CHOLMOD itself solves
all the columns of a dense right-hand side together, its supernodal
triangular solves then being matrix–matrix (BLAS-3) products. This module
calls ``cholmod_l_solve`` through :mod:`ctypes` in cvxopt's bundled
libcholmod, the library that already holds the factor (no second
factorization, no new dependency).

Measured (``bench/bench_cholesky.py``, the roof's first Jacobian of its
refinement: 17 112 unknowns, 289 right-hand sides), see the README.

The call relies on CHOLMOD's public structs (``cholmod_dense``; the first
two fields of ``cholmod_factor``) and on cvxopt handing its factor out as a
capsule named ``"CHOLMOD FACTOR D L"`` (real, 64-bit indices). Where any of
that is not as expected (no such library, another CHOLMOD major version, a
capsule of another kind, a factor of another size or an incomplete one),
:func:`solve_many` returns None and the caller keeps cvxopt's per-column
solve: the answer is the same either way, to rounding.
"""

from __future__ import annotations

import ctypes
import functools
import threading

import numpy as np

__all__ = ["solve_many", "available"]

_CAPSULE = b"CHOLMOD FACTOR D L"     # cvxopt: a real factor, CHOLMOD's long-integer interface
_CHOLMOD_A = 0                      # solve A x = b (the permutation included)
_CHOLMOD_REAL = 1
_CHOLMOD_DOUBLE = 0


class _Dense(ctypes.Structure):
    """``cholmod_dense`` (cholmod.h, unchanged from CHOLMOD 1 to 5)."""

    _fields_ = [("nrow", ctypes.c_size_t), ("ncol", ctypes.c_size_t), ("nzmax", ctypes.c_size_t),
                ("d", ctypes.c_size_t), ("x", ctypes.c_void_p), ("z", ctypes.c_void_p),
                ("xtype", ctypes.c_int), ("dtype", ctypes.c_int)]


class _Library:
    """cvxopt's libcholmod with one ``cholmod_common`` of its own (used under a lock)."""

    def __init__(self, lib: ctypes.CDLL):
        lib.cholmod_l_start.argtypes = [ctypes.c_void_p]
        lib.cholmod_l_solve.restype = ctypes.POINTER(_Dense)
        lib.cholmod_l_solve.argtypes = [ctypes.c_int, ctypes.c_void_p, ctypes.POINTER(_Dense), ctypes.c_void_p]
        lib.cholmod_l_free_dense.argtypes = [ctypes.POINTER(ctypes.POINTER(_Dense)), ctypes.c_void_p]
        self.lib = lib
        # cholmod_common is a few kB in every CHOLMOD version: 64 kB holds it with room to spare
        self.common = ctypes.create_string_buffer(1 << 16)
        if lib.cholmod_l_start(self.common) != 1:
            raise OSError("cholmod_l_start failed")
        self.lock = threading.Lock()


@functools.cache
def _library() -> _Library | None:
    """cvxopt's libcholmod when it is CHOLMOD 3 to 5 with the long-integer interface; else None."""
    from inflation.cholesky import cvxopt_bundled_library

    try:
        lib = cvxopt_bundled_library("cholmod")     # the library cvxopt has loaded: the same handle
        if lib is None:
            return None
        version = (ctypes.c_int * 3)()
        lib.cholmod_l_version(version)
        if not 3 <= version[0] <= 5:
            return None
        return _Library(lib)
    except (OSError, AttributeError):
        return None


def available() -> bool:
    """Whether :func:`solve_many` can solve here (else it always returns None)."""
    return _library() is not None


_api = ctypes.pythonapi
_api.PyCapsule_GetName.restype = ctypes.c_char_p
_api.PyCapsule_GetName.argtypes = [ctypes.py_object]
_api.PyCapsule_GetPointer.restype = ctypes.c_void_p
_api.PyCapsule_GetPointer.argtypes = [ctypes.py_object, ctypes.c_char_p]


def solve_many(factor, b: np.ndarray) -> np.ndarray | None:
    """Solve ``A X = B`` for all columns of ``B`` at once with cvxopt's CHOLMOD factor of ``A``.

    Parameters
    ----------
    factor : PyCapsule
        A complete numeric factor from ``cvxopt.cholmod.numeric`` (real).
    b : ndarray of shape (n, k)
        Right-hand sides (any units; X has b's units over A's).

    Returns
    -------
    ndarray of shape (n, k), or None
        X; None when the factor or the library is not one this module can use
        (then solve column by column with ``cvxopt.cholmod.solve``).
    """
    lib = _library()
    b = np.asarray(b, dtype=float)
    if lib is None or b.ndim != 2 or b.size == 0:
        return None
    try:
        if _api.PyCapsule_GetName(factor) != _CAPSULE:
            return None
        ptr = _api.PyCapsule_GetPointer(factor, _CAPSULE)
    except (TypeError, ValueError):
        return None
    n, k = b.shape
    head = (ctypes.c_size_t * 2).from_address(ptr)  # cholmod_factor: n, then minor (= n when complete)
    if head[0] != n or head[1] != n:
        return None
    bf = np.asfortranarray(b)
    rhs = _Dense(n, k, n * k, n, bf.ctypes.data, None, _CHOLMOD_REAL, _CHOLMOD_DOUBLE)
    with lib.lock:
        out = lib.lib.cholmod_l_solve(_CHOLMOD_A, ptr, ctypes.byref(rhs), lib.common)
        if not out:
            return None
        try:
            d = out.contents
            if (d.nrow, d.ncol, d.d, d.xtype) != (n, k, n, _CHOLMOD_REAL):
                return None
            x = np.ctypeslib.as_array(ctypes.cast(d.x, ctypes.POINTER(ctypes.c_double)), shape=(k, n)).T.copy()
        finally:
            lib.lib.cholmod_l_free_dense(ctypes.byref(out), lib.common)
    return x
