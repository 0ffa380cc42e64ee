"""The inflation simulator (paper §3.4): the mattress inflated with its strings, by minimising U_B.

Public API (SI units: metres, pascals, 1/m):

- :func:`build_mattress_mesh` -- the closed double-layer mesh M′ (``mesh``).
- :class:`StringSet` -- external strings on Ω with their simulated lengths l* (``strings``).
- :class:`Parameters`, :func:`build_model` -- the terms of U_B (``model``, ``energy``).
- :func:`solve` -- Newton / trust-region minimisation of U_B (``solver``, ``cholesky``).
- :func:`inflate`, :func:`inflate_many` -- string ramp + coarse-to-fine solves (``simulate``, ``prolong``).

Comparing an inflation with Ŝ is the check's job (the ``check`` package).
"""

from inflation.mesh import MattressMesh, build_mattress_mesh
from inflation.model import Parameters, build_model
from inflation.simulate import Inflation, inflate, inflate_many
from inflation.solver import SolveResult, solve
from inflation.strings import StringSet

__all__ = [
    "MattressMesh", "build_mattress_mesh", "StringSet", "Parameters", "build_model",
    "SolveResult", "solve", "Inflation", "inflate", "inflate_many",
]
