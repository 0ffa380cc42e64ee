"""CHOLMOD's solve of many right-hand sides at once, on a factor that cvxopt holds.

cvxopt's ``cholmod.solve`` calls CHOLMOD once per column of the right-hand
side, and every call streams the whole factor through memory: the adjoint
Jacobian of the refinement (:func:`airmat.check.adjoint.equilibrium_jacobian`, one
column per string) is then bound by memory bandwidth. CHOLMOD itself solves
all the columns of a dense right-hand side together, its supernodal
triangular solves then being matrix–matrix (BLAS-3) products. This module
calls ``cholmod_l_solve`` through :mod:`ctypes` in cvxopt's bundled
libcholmod, the library that already holds the factor (no second
factorization, no new dependency).

Measured (``bench/bench_jacobian_solve.py``, the roof's Jacobian on the
refinement's 40 mm mesh: 17 112 unknowns, 289 right-hand sides): ``docs/benchmarks.md``.

cvxopt's OpenBLAS is a sequential build, so one CHOLMOD call runs on one core.
A large right-hand side (at least ``MIN_SPLIT`` entries) is split in two
column blocks solved side by side on two threads when another core is idle
(:func:`airmat.cores.idle_cores`; ctypes lets go of the GIL during the
call), each with a ``cholmod_common`` of its own. The blocks start at
multiples of ``ALIGN`` columns: a column's BLAS-3 arithmetic then does not
depend on the block it is in, and the answer is the same bits with one
thread or two (tested; the OpenBLAS kernel families SkylakeX, Haswell,
Zen, Sandybridge, Cooperlake and Prescott were checked by hand: Prescott's
kernels need 4, Haswell's 2, whereas a block boundary at an odd column
changes the last bit there).

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
import os
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from airmat.cores import idle_cores
from airmat.inflation.cvxopt_libs import cvxopt_bundled_library

__all__ = ["solve_many", "available", "column_blocks", "ALIGN", "MIN_SPLIT"]

#: a right-hand side is split only at multiples of this many columns (see the module docstring)
ALIGN = 8

#: nor below this many entries (unknowns x columns): the roof's Jacobian on its 40 mm mesh has 4.9 M,
#: vault1's 0.13 M (a 6 ms solve, which a thread would not shorten)
MIN_SPLIT = 1_000_000

_CAPSULE = b"CHOLMOD FACTOR D L"     # cvxopt: a real factor, CHOLMOD's long-integer interface
_CHOLMOD_A = 0                      # solve A x = b (the permutation included)
_CHOLMOD_REAL = 1
_CHOLMOD_DOUBLE = 0


class _Dense(ctypes.Structure):
    """``cholmod_dense`` (cholmod.h, unchanged from CHOLMOD 1 to 5)."""

    _fields_ = [("nrow", ctypes.c_size_t), ("ncol", ctypes.c_size_t), ("nzmax", ctypes.c_size_t),
                ("d", ctypes.c_size_t), ("x", ctypes.c_void_p), ("z", ctypes.c_void_p),
                ("xtype", ctypes.c_int), ("dtype", ctypes.c_int)]


class _Common:
    """One ``cholmod_common`` (CHOLMOD's workspace and settings), used under its lock."""

    def __init__(self, lib: ctypes.CDLL):
        # cholmod_common is a few kB in every CHOLMOD version: 64 kB holds it with room to spare
        self.buffer = ctypes.create_string_buffer(1 << 16)
        if lib.cholmod_l_start(self.buffer) != 1:
            raise OSError("cholmod_l_start failed")
        self.lock = threading.Lock()


class _Library:
    """cvxopt's libcholmod with two ``cholmod_common`` of its own, one per thread of a split solve."""

    def __init__(self, lib: ctypes.CDLL):
        lib.cholmod_l_start.argtypes = [ctypes.c_void_p]
        lib.cholmod_l_solve.restype = ctypes.POINTER(_Dense)
        lib.cholmod_l_solve.argtypes = [ctypes.c_int, ctypes.c_void_p, ctypes.POINTER(_Dense), ctypes.c_void_p]
        lib.cholmod_l_free_dense.argtypes = [ctypes.POINTER(ctypes.POINTER(_Dense)), ctypes.c_void_p]
        self.lib = lib

    @property
    def commons(self) -> tuple[_Common, _Common]:
        """This process's two commons (a forked child makes its own: a lock held at the fork stays held)."""
        return _commons(self, os.getpid())

    def solve(self, ptr, b: np.ndarray, common: _Common) -> np.ndarray | None:
        """X with ``A X = b`` for a dense block ``b`` (n, k) on the factor at ``ptr``; None if CHOLMOD says no."""
        n, k = b.shape
        bf = np.asfortranarray(b)
        rhs = _Dense(n, k, n * k, n, bf.ctypes.data, None, _CHOLMOD_REAL, _CHOLMOD_DOUBLE)
        with common.lock:
            out = self.lib.cholmod_l_solve(_CHOLMOD_A, ptr, ctypes.byref(rhs), common.buffer)
            if not out:
                return None
            try:
                d = out.contents
                if (d.nrow, d.ncol, d.d, d.xtype) != (n, k, n, _CHOLMOD_REAL):
                    return None
                return np.ctypeslib.as_array(ctypes.cast(d.x, ctypes.POINTER(ctypes.c_double)), shape=(k, n)).T.copy()
            finally:
                self.lib.cholmod_l_free_dense(ctypes.byref(out), common.buffer)


@functools.cache
def _commons(library: _Library, pid: int) -> tuple[_Common, _Common]:
    return _Common(library.lib), _Common(library.lib)


@functools.cache
def _second_thread(pid: int) -> ThreadPoolExecutor:
    """The thread that solves a split right-hand side's second block, one per process (a forked
    child inherits its parent's pool but not the pool's thread, and would wait for it forever)."""
    return ThreadPoolExecutor(max_workers=1, thread_name_prefix="airmat-cholmod")


def column_blocks(n: int, k: int, threads: int) -> list[tuple[int, int]]:
    """The column blocks ``[(start, stop), ...]`` of an (n, k) right-hand side solved on ``threads`` threads.

    Two blocks when ``threads >= 2`` and the right-hand side has at least ``MIN_SPLIT``
    entries: split at the multiple of ``ALIGN`` nearest to half, each block at least
    ``ALIGN`` columns wide; else one block.

    Examples
    --------
    >>> column_blocks(17112, 289, 2), column_blocks(17112, 289, 1), column_blocks(3144, 41, 2)
    ([(0, 144), (144, 289)], [(0, 289)], [(0, 41)])
    """
    m = ALIGN * int(round(k / (2 * ALIGN)))
    if threads < 2 or n * k < MIN_SPLIT or m < ALIGN or k - m < ALIGN:
        return [(0, k)]
    return [(0, m), (m, k)]


@functools.cache
def _library() -> _Library | None:
    """cvxopt's libcholmod when it is CHOLMOD 3 to 5 with the long-integer interface; else None."""
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


def solve_many(factor, b: np.ndarray, threads: int | None = None) -> np.ndarray | None:
    """Solve ``A X = B`` for all columns of ``B`` at once with cvxopt's CHOLMOD factor of ``A``.

    Parameters
    ----------
    factor : PyCapsule
        A complete numeric factor from ``cvxopt.cholmod.numeric`` (real).
    b : ndarray of shape (n, k)
        Right-hand sides (any units; X has b's units over A's).
    threads : int, optional
        Threads for a large ``b`` (:func:`column_blocks`); default: 2 when another core is
        idle (:func:`airmat.cores.idle_cores`), else 1. The answer is the same bits either way.

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
    if threads is None:     # a small right-hand side stays one call: no need to read the load
        threads = 1 if n * k < MIN_SPLIT else idle_cores(samples=1)
    blocks = column_blocks(n, k, threads)
    if len(blocks) == 1:
        return lib.solve(ptr, b, lib.commons[0])
    (a0, a1), (b0, b1) = blocks
    second = _second_thread(os.getpid()).submit(lib.solve, ptr, b[:, b0:b1], lib.commons[1])
    first = lib.solve(ptr, b[:, a0:a1], lib.commons[0])
    rest = second.result()
    return None if first is None or rest is None else np.hstack([first, rest])
