"""The refinement's set-up: the open-loop inflation, the trial problem, the bounds, the stopping tolerances.

:func:`set_up_problem` checks what :func:`airmat.check.refinement.refine` is given (:func:`check_refinable`),
inflates the given lengths from the flat mattress at the target resolution (a refined design from its first
open loop on), builds the trial equilibria and bounds each length between the shortest a tie allows and the
string's flat span (:func:`length_bounds`). :func:`coarse_resolution` picks the two-level scheme's coarse
mesh; :func:`solver_options` gives the Gauss–Newton keywords every stage shares. SI units (m).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from airmat.check.compare import Deviation, deviation
from airmat.check.inflation_check import design_strings, named_face, open_loop_strings
from airmat.check.length_map import length_map
from airmat.check.refinement_result import RMS_TOL_PER_DIAGONAL, RefineOptions
from airmat.check.trial_equilibrium import TrialProblem, make_problem
from airmat.errors import InputError
from airmat.inflation.mesh import MattressMesh, build_mattress_mesh
from airmat.inflation.simulate import Inflation, inflate, inflate_from
from airmat.inflation.strings import StringSet, check_resolution

__all__ = ["RefineProblem", "set_up_problem", "check_refinable", "length_bounds", "coarse_resolution",
           "solver_options", "rms_tolerance"]


@dataclass(frozen=True)
class RefineProblem:
    """What every stage of :func:`~airmat.check.refinement.refine` starts from (:func:`set_up_problem`); SI units.

    Attributes
    ----------
    design : airmat.design.pipeline.DesignResult
        The design being refined.
    strings : airmat.inflation.strings.StringSet
        Its strings at their median lengths (simulated rest lengths l*, m).
    open_loop : airmat.inflation.strings.StringSet or None
        A refined design's first open-loop strings (it is inflated from them on); None for an open-loop design.
    mesh : airmat.inflation.mesh.MattressMesh
        The mattress at the target resolution.
    surface : str
        The named face.
    flat_inflation : airmat.inflation.simulate.Inflation
        The inflation from the flat mattress at the open-loop lengths (its continuation levels kept).
    inflation_seconds : float
        Its wall time (s).
    start : airmat.inflation.simulate.Inflation
        The equilibrium at the given lengths (``flat_inflation`` carried on to them for a refined design).
    deviation_before : airmat.check.compare.Deviation
        Of ``start`` from the designed Ŝ.
    problem : airmat.check.trial_equilibrium.TrialProblem
        The trial equilibria at the target resolution.
    lower, upper : ndarray of shape (k,)
        Bounds of the lengths (m): the shortest a tie allows, the flat span.
    l_start : ndarray of shape (k,)
        The given lengths clipped to the bounds (m): the start and the Tikhonov term's target.
    lengths_before : {"open-loop", "refined"}
        What the given design's lengths are.
    """

    design: object
    strings: StringSet
    open_loop: StringSet | None
    mesh: MattressMesh
    surface: str
    flat_inflation: Inflation
    inflation_seconds: float
    start: Inflation
    deviation_before: Deviation
    problem: TrialProblem
    lower: np.ndarray
    upper: np.ndarray
    l_start: np.ndarray
    lengths_before: str

    @property
    def flat_strings(self) -> StringSet:
        """The strings ``flat_inflation`` was inflated with."""
        return self.strings if self.open_loop is None else self.open_loop


def coarse_resolution(resolution: float, span: np.ndarray, coarsest: float) -> float | None:
    """The two-level scheme's coarse mesh edge (m): twice ``resolution``, or None.

    None when twice ``resolution`` exceeds ``coarsest`` (m) or leaves fewer than 4 edges
    along the shortest ``span`` (shape (k,), m).
    """
    coarse = 2.0 * resolution
    if coarse > coarsest * (1 + 1e-9) or coarse * 4.0 > float(np.min(span)):
        return None
    return coarse


def length_bounds(design, strings: StringSet) -> tuple:
    """Bounds of the simulated lengths l* (m), each an ndarray of shape (k,).

    The lower bound is the shortest a tie allows (real length 0 through the calibration's
    length map, at most half the span); the upper one the string's flat span (no bend).
    """
    span = np.linalg.norm(strings.b - strings.a, axis=1)
    lower = np.minimum(length_map(design.calibration).to_simulated(np.zeros(len(span))), 0.5 * span)
    return lower, span


def check_refinable(design, resolution: float, path=None) -> None:
    """Refuse, before any work, what :func:`~airmat.check.refinement.refine` cannot refine.

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
    resolution : float
        The refinement's mesh edge length (m).
    path : str or PathLike, optional
        The file the design was read from: named by the errors about its content.

    Raises
    ------
    airmat.errors.InputError
        No strings, a resolution too coarse for them (:func:`~airmat.inflation.strings.check_resolution`),
        or no posterior samples in the design's calibration.
    """
    if len(design.pattern.strings) == 0:
        raise InputError("the design has no strings: nothing to refine", path=path)
    if getattr(design.calibration, "n_samples", 0) == 0:
        raise InputError("the design's calibration has no posterior samples: a refined length's "
                         "tolerance cannot be computed", path=path)
    check_resolution(design_strings(design, "median"), resolution)


def set_up_problem(design, options: RefineOptions) -> RefineProblem:
    """Check the input, inflate the given lengths and set up the trial equilibria and the bounds.

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
    options : RefineOptions

    Returns
    -------
    RefineProblem

    Raises
    ------
    airmat.errors.InputError
        What :func:`check_refinable` refuses, or a negative ``options.reparametrize``.
    """
    check_refinable(design, options.resolution)
    lengths_before = "open-loop" if design.refine is None else "refined"
    if options.reparametrize < 0:
        raise InputError(f"refinement: reparametrize must be 0 or more rounds, got {options.reparametrize}")
    strings = design_strings(design, "median")
    open_loop = open_loop_strings(design)      # a refined design is inflated from its open loop on
    mesh = build_mattress_mesh(design.mattress.width, design.mattress.height, design.mattress.thickness,
                               resolution=options.resolution)
    surface = named_face(design, strings) if options.surface == "auto" else options.surface
    started = time.perf_counter()
    flat_inflation = inflate(mesh, strings if open_loop is None else open_loop, params=options.params,
                             tol=options.tol, keep_levels=True)
    inflation_seconds = time.perf_counter() - started
    start = flat_inflation if open_loop is None else inflate_from(flat_inflation, strings, params=options.params,
                                                                  tol=options.tol)
    deviation_before = deviation(start, design.approx.xyz, design.approx.uv, surface)
    problem = make_problem(mesh, strings, options.params, design, surface, options.tol)
    lower, upper = length_bounds(design, strings)
    return RefineProblem(design=design, strings=strings, open_loop=open_loop, mesh=mesh, surface=surface,
                         flat_inflation=flat_inflation, inflation_seconds=inflation_seconds, start=start,
                         deviation_before=deviation_before, problem=problem, lower=lower, upper=upper,
                         l_start=np.clip(strings.rest, lower, upper), lengths_before=lengths_before)


def solver_options(setup: RefineProblem, options: RefineOptions) -> dict:
    """The keywords of :func:`~airmat.check.gauss_newton.gauss_newton` every stage shares (``xtol`` and ``rms_tol`` in m)."""
    return dict(alpha=options.alpha, ftol=options.ftol, xtol=options.xtol * float(np.mean(setup.upper)),
                rms_tol=rms_tolerance(setup.design.mattress, options.rms_tol))


def rms_tolerance(mattress, rms_tol: float | None) -> float:
    """The stopping rule's RMS decrease (m): ``rms_tol``, or :data:`RMS_TOL_PER_DIAGONAL` of ``mattress``'s diagonal.

    Examples
    --------
    >>> from airmat.design.mattress import Mattress
    >>> round(rms_tolerance(Mattress(0.83, 0.74), None) * 1e3, 3), rms_tolerance(Mattress(0.83, 0.74), 1e-4)
    (0.05, 0.0001)
    """
    if rms_tol is not None:
        return float(rms_tol)
    return RMS_TOL_PER_DIAGONAL * float(np.hypot(mattress.width, mattress.height))
