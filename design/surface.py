"""The surface side of the designer in one call: target S -> Ŝ -> curvature field on Ω.

:func:`approximate_surface` triangulates Ω, relaxes it onto S (U_A,
airmat.design.relax), estimates Ŝ's principal curvatures (airmat.design.curvature) and
reports constructibility (airmat.design.constructibility);
:func:`mattress_field` carries the curvature field onto Ω
(airmat.design.transfer) for the pattern side. SI units: m, 1/m.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np

from airmat.errors import ConvergenceError
from airmat.design.closest_point import MeshProjector
from airmat.design.constructibility import PAPER_KAPPA_MAX, ConstructibilityReport, constructibility
from airmat.design.curvature import PrincipalCurvature, principal_curvature
from airmat.design.face_metric import relax_in_face_metric
from airmat.design.field import MattressField
from airmat.design.mattress import Mattress, triangulate_mattress
from airmat.design.relax import RelaxResult, relax_to_target
from airmat.design.target import Target, check_scale
from airmat.design.transfer import transfer_to_mattress

__all__ = ["ApproxSurface", "approximate_surface", "mattress_field"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ApproxSurface:
    """Ŝ: the near-developable surface the mattress can make, with its curvature and report.

    A Ŝ read back from a design folder (:func:`airmat.design.design_io.read_design`)
    has ``relax`` and ``curvature`` None: the files keep Ŝ, its Ω coordinates, the
    target S (``target.ply``; ``target`` is None for a folder written before it) and
    the report, not the relaxation's history.

    Attributes
    ----------
    target : airmat.design.target.Target or None
    mattress : airmat.design.mattress.Mattress
    xyz : ndarray of shape (n, 3)
        Vertices of Ŝ (m).
    uv : ndarray of shape (n, 2)
        The same vertices on Ω (m).
    faces : ndarray of shape (m, 3)
        Shared triangles, counter-clockwise on Ω.
    relax : airmat.design.relax.RelaxResult or None
        The U_A relaxation (converged, n_iter, residual, message, energy, placement).
    curvature : airmat.design.curvature.PrincipalCurvature or None
        Per-vertex principal curvatures of Ŝ, signed against the top normal.
    report : airmat.design.constructibility.ConstructibilityReport or None
        Table-1 figures and verdict (None for a design folder written by another tool).
    timings : dict
        Seconds per stage: ``triangulate``, ``relax``, ``curvature``, ``report``.
    """

    target: Target | None
    mattress: Mattress
    xyz: np.ndarray
    uv: np.ndarray
    faces: np.ndarray
    relax: RelaxResult | None
    curvature: PrincipalCurvature | None
    report: ConstructibilityReport | None
    timings: dict = field(default_factory=dict, compare=False)


def approximate_surface(target: Target, mattress: Mattress, *, spacing: float = 0.02, placement=None,
                        k_a1: float = 1.0, k_a2: float = 0.2, k_a3: float = 0.02, tol: float = 1e-4,
                        max_iter: int = 1000, stall: float = 1e-7, sigma_band=(0.9, 1.1),
                        kappa_max: float | None = None,
                        curvature_radius: float = 2.5, progress: bool = True,
                        strict: bool = False, face_metric: bool = True,
                        kappa_min: float = 0.25, string_margin: float = 0.03, folds: bool = False) -> ApproxSurface:
    """Find Ŝ for ``target`` on ``mattress`` and its principal curvatures (paper §3.2).

    Parameters
    ----------
    target : airmat.design.target.Target or mesh
        The guide surface S (m); any object with ``vertices``, ``faces`` and ``name``
        (e.g. an analytic surface of airmat.synthetic.targets) is taken as a Target
        (:meth:`airmat.design.target.Target.from_mesh`).
    mattress : airmat.design.mattress.Mattress
    spacing : float, default 0.02
        Mesh spacing on Ω (m).
    placement : (4, 4) ndarray or (offset, rotation), optional
        Start placement of Ω (airmat.design.placement); default: centred on S's principal frame.
    k_a1, k_a2, k_a3 : float, default 1.0, 0.2, 0.02
        U_A weights (airmat.design.relax.relax_to_target; k_a2, k_a3 at 20 mm spacing).
    tol, stall, max_iter : float, float, int
        Relaxation stopping rule (airmat.design.relax.relax_to_target).
    sigma_band : (float, float), default (0.9, 1.1)
        Tolerated edge length ratio Ŝ/Ω (airmat.design.constructibility).
    kappa_max : float, optional
        Reachable curvature (1/m); default the paper's calibration (15.66 1/m).
    curvature_radius : float, default 2.5
        Neighbourhood of the curvature fit, in mean edge lengths.
    progress : bool, default True
        Progress bar on the relaxation (only on a terminal).
    strict : bool, default False
        Raise ConvergenceError when the relaxation does not converge.
    face_metric : bool, default True
        Relax Ŝ again in the metric of the face it stands for
        (:func:`airmat.design.face_metric.relax_in_face_metric`, with the mattress's thickness):
        where the curvature has both signs (a saddle), that face carries the minority
        family's strings and shortens along them. A design whose curvature has one
        sign is unchanged. False: Ω's metric everywhere (the paper's A1).
    kappa_min : float, default 0.25
        |κ| (1/m) below which a family needs no string (and shortens no face).
    string_margin : float, default 0.03
        Dashes stay this far inside the mattress edge (m): no string shortens a face there.
    folds : bool, default False
        Ŝ may fold (:mod:`airmat.design.fold_route`): the verdict counts the curvature beyond
        reach as folds while they are few (:func:`airmat.design.constructibility.constructibility`).

    Returns
    -------
    ApproxSurface

    Raises
    ------
    airmat.errors.InputError
        When the target does not fit the mattress (a units slip) or a parameter is invalid.
    airmat.errors.ConvergenceError
        When the relaxation diverges (or, with ``strict``, does not converge).
    """
    target = Target.from_mesh(target)
    check_scale(target, mattress)
    timings = {}
    t = time.perf_counter()
    uv, faces = triangulate_mattress(mattress, spacing=spacing)
    projector = MeshProjector(target.vertices, target.faces)
    timings["triangulate"] = time.perf_counter() - t
    t = time.perf_counter()
    relax = relax_to_target(uv, faces, target, placement=placement, k_a1=k_a1, k_a2=k_a2, k_a3=k_a3,
                            tol=tol, stall=stall, max_iter=max_iter, progress=progress, strict=strict,
                            projector=projector)
    timings["relax"] = time.perf_counter() - t
    t = time.perf_counter()
    curv = principal_curvature(relax.xyz, faces, radius=curvature_radius)
    timings["curvature"] = time.perf_counter() - t
    metric = None
    if face_metric:
        t = time.perf_counter()
        again, metric = relax_in_face_metric(relax, uv, faces, projector, thickness=mattress.thickness,
                                             kappa_min=kappa_min, margin=string_margin, curvature=curv,
                                             curvature_radius=curvature_radius,
                                             kappa_max=PAPER_KAPPA_MAX if kappa_max is None else kappa_max, k_a1=k_a1,
                                             k_a2=k_a2, k_a3=k_a3, tol=tol, stall=stall, max_iter=max_iter)
        if again is not relax:                 # Ŝ moved: its curvature too (a one-signed Ŝ keeps both)
            relax = again
            curv = principal_curvature(relax.xyz, faces, radius=curvature_radius)
        timings["relax"] += time.perf_counter() - t         # the rounds in the face metric are relaxation
        if strict and not relax.converged:
            raise ConvergenceError(f"U_A relaxation {relax.message}", n_iter=relax.n_iter, residual=relax.residual)
    t = time.perf_counter()
    report = constructibility(relax.xyz, uv, faces, curv.kappa, sigma_band=sigma_band, kappa_max=kappa_max,
                              off_target=relax.off_target, metric=metric, folds=folds)
    timings["report"] = time.perf_counter() - t
    for warning in report.warnings:
        log.warning("Ŝ of %s: %s", target.name, warning)
    if not report.constructible:
        log.warning("Ŝ of %s is not constructible: %s", target.name, "; ".join(report.reasons))
    return ApproxSurface(target=target, mattress=mattress, xyz=relax.xyz, uv=uv, faces=faces, relax=relax,
                         curvature=curv, report=report, timings=timings)


def mattress_field(approx: ApproxSurface, *, smoothing_length: float = 0.03,
                   anisotropy_scale: float = 0.5) -> MattressField:
    """The principal-curvature field of Ŝ carried onto Ω (airmat.design.transfer.transfer_to_mattress).

    Parameters
    ----------
    approx : ApproxSurface
    smoothing_length : float, default 0.03
        Length (m) over which unreliable (umbilic) directions are filled in.
    anisotropy_scale : float, default 0.5
        a0 (1/m) of the direction reliability weight.

    Returns
    -------
    airmat.design.field.MattressField
        With ``meta`` holding the target name, the Table-1 report and the relaxation message.
    """
    m = approx.mattress
    meta = {"target": approx.target.name, "report": approx.report, "relax": approx.relax.message}
    return transfer_to_mattress(approx.xyz, approx.uv, approx.faces, approx.curvature.kappa,
                                approx.curvature.directions, width=m.width, height=m.height,
                                smoothing_length=smoothing_length, anisotropy_scale=anisotropy_scale,
                                meta=meta)
