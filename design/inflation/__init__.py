"""The inflation check (paper §3.4): the mattress inflated with its strings, by minimising U_B.

Public API (SI units: metres, pascals, 1/m):

- :func:`build_mattress_mesh` -- the closed double-layer mesh M′ (``mesh``).
- :class:`StringSet` -- external strings on Ω with their simulated lengths l* (``strings``).
- :class:`Parameters`, :func:`build_model` -- the terms of U_B (``model``, ``energy``).
- :func:`solve` -- Newton / trust-region minimisation of U_B (``solver``).
- :func:`inflate` -- string ramp + solves: the inflated mattress (``simulate``).
- :func:`read_design_folder`, :func:`check_design` -- a design's inflation check and its
  tolerance envelope (``design_folder``, ``check``, ``compare``, ``report``).
- :func:`validate_equation3` -- the simulated specimen experiment (``validation``).
"""

from design.inflation.check import CheckRun, DesignCheck, check_design
from design.inflation.compare import Deviation, deviation, realized_curvature, surface_at
from design.inflation.design_folder import DesignFolder, read_design_folder
from design.inflation.mesh import MattressMesh, build_mattress_mesh
from design.inflation.model import Parameters, build_model
from design.inflation.simulate import Inflation, inflate
from design.inflation.solver import SolveResult, solve
from design.inflation.strings import StringSet

__all__ = [
    "MattressMesh", "build_mattress_mesh", "StringSet", "Parameters", "build_model",
    "SolveResult", "solve", "Inflation", "inflate", "DesignFolder", "read_design_folder",
    "Deviation", "deviation", "realized_curvature", "surface_at", "CheckRun", "DesignCheck",
    "check_design", "validate_equation3",
]


def __getattr__(name):  # validation imports calib's cylinder fit: load it only when asked for
    if name == "validate_equation3":
        from design.inflation.validation import validate_equation3

        return validate_equation3
    raise AttributeError(name)
