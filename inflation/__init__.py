"""The inflation simulator (paper §3.4): the mattress inflated with its strings, by minimising U_B.

Public API (SI units: metres, pascals, 1/m):

- :func:`build_mattress_mesh` -- the closed double-layer mesh M′ (``mesh``).
- :class:`StringSet` -- external strings on Ω with their simulated lengths l* (``strings``).
- :class:`Parameters`, :func:`build_model` -- the terms of U_B (``model``, ``energy``).
- :func:`solve` -- Newton / trust-region minimisation of U_B (``solver``, ``cholesky``).
- :func:`inflate`, :func:`inflate_many` -- string ramp + coarse-to-fine solves (``simulate``, ``prolong``);
  :func:`inflate_from` -- an equilibrium carried on to other strings (a refined design's path).
- :func:`map_shared` -- the one executor of independent runs: serial or on Dask (``executor``).

Comparing an inflation with Ŝ is the check's job (the ``check`` package).
"""

import airmat  # noqa: F401  (sets the BLAS thread defaults before numpy loads)
from airmat.lazy import attach

# public name -> its submodule, imported on first use (``airmat.lazy``): ``import airmat.inflation.mesh``
# runs this file first, and it must not load the solver and cvxopt
__getattr__, __dir__, __all__ = attach(__name__, {
    "mesh": ["MattressMesh", "build_mattress_mesh"],
    "strings": ["StringSet"],
    "model": ["Parameters", "build_model"],
    "solver": ["SolveResult", "solve"],
    "simulate": ["Inflation", "inflate", "inflate_from", "inflate_many"],
    "executor": ["map_shared", "scheduler_address"],
})
