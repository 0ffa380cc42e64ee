"""Ŝ in the metric of the face it stands for: the named face shortens where it carries strings.

The check compares Ŝ with the face that keeps its length: the face opposite
the strings (:func:`length_keeping_face`, the top face when
the bottom strings, κ > 0, carry the larger share of the bending). On a
design whose curvature has one sign (a vault, a cylinder) that face carries
no string and keeps Ω's lengths, as the paper's A1 assumes. On a saddle the
minority family's strings sit on the named face itself: along their
direction that face is the string face and shortens, by the ratio of its
radius to the free face's, 1 / (1 + d |κ|) (d the mattress thickness, κ the
named face's normal curvature; measured on the saddle: 0.92–0.94 of flat
along u where Ŝ in Ω's metric keeps 0.97–1.02; bench_face_strain in docs/decisions.md). No
string length can make a face longer than its metric, so such a Ŝ lies 2.6 % of the
diagonal from what the mattress makes.

:func:`face_metric` gives each edge of Ω the rest length of the named face:
its flat length times 1 / (1 + d κₙ⁻), κₙ⁻ the normal curvature along the
edge of the principal curvatures of the minority sign where they need a
string (|κ| ≥ ``kappa_min``; elsewhere no string shortens the face). Which face
is named follows the check's rule, applied to the curvature field instead of
the strings (:func:`named_face`).
:func:`relax_in_face_metric` relaxes Ŝ again in that metric, a few rounds,
each from the last Ŝ and with the metric of its curvature. A design whose
curvature has one sign is left exactly as it was. SI units (m, 1/m).
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass

import numpy as np

from airmat.geometry.topology import flat_vertex_areas, mesh_edges

__all__ = ["FaceMetric", "face_metric", "named_face", "length_keeping_face", "strings_named_face", "relax_in_face_metric", "ROUNDS"]

log = logging.getLogger(__name__)

#: relaxations in the face metric, each with the metric of the last Ŝ's curvature
ROUNDS = 2


@dataclass(frozen=True)
class FaceMetric:
    """The named face's rest length per edge of Ω.

    Attributes
    ----------
    face : str
        ``"top"`` or ``"bottom"``: the face Ŝ stands for.
    rest : ndarray of shape (e,)
        Rest length (m) of each edge of ``mesh_edges(faces)`` on that face.
    ratio : ndarray of shape (e,)
        ``rest`` over the edge's length on Ω, in (0, 1]: 1 where the face carries no string.
    """

    face: str
    rest: np.ndarray
    ratio: np.ndarray

    @property
    def flat(self) -> bool:
        """True when the face keeps Ω's lengths everywhere (a one-signed design)."""
        return bool(np.all(self.ratio == 1.0))

    def summary(self) -> dict:
        """``{"face", "min_ratio"}``: for the constructibility report."""
        return {"face": self.face, "min_ratio": float(self.ratio.min()) if self.ratio.size else 1.0}


def named_face(kappa, uv, faces, *, kappa_min: float = 0.25) -> str:
    """The face Ŝ stands for: opposite the sign of curvature that needs more string.

    Parameters
    ----------
    kappa : ndarray of shape (n, 2)
        Signed principal curvatures (1/m), positive bending away from the top face.
    uv, faces : ndarray of shape (n, 2), (m, 3)
        Ω's triangulation (m): the area weights.
    kappa_min : float
        |κ| (1/m) below which no string is needed.

    Returns
    -------
    str
        ``"top"`` when the area integral of the positive curvatures that need a string
        (the bottom strings') is at least the negative ones', else ``"bottom"``: the rule
        of :func:`length_keeping_face`, on the field instead of the strings.

    Examples
    --------
    >>> uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    >>> named_face(np.array([[2.0, -1.0]] * 3), uv, np.array([[0, 1, 2]]))
    'top'
    >>> named_face(np.array([[-2.0, 1.0]] * 3), uv, np.array([[0, 1, 2]]))
    'bottom'
    """
    kappa = np.asarray(kappa, float)
    need = np.where(np.abs(kappa) >= kappa_min, kappa, 0.0)
    area = flat_vertex_areas(uv, faces)
    pos, neg = area @ np.maximum(need, 0).sum(axis=1), area @ np.maximum(-need, 0).sum(axis=1)
    return "top" if pos >= neg else "bottom"


def length_keeping_face(weights, top) -> str:
    """The face Ŝ stands for: opposite the larger share of bending.

    Parameters
    ----------
    weights : ndarray of shape (k,)
        Each string's share: |κ| times its span on Ω (the string face shortens by
        about that times d; any nonnegative weight, e.g. spans alone).
    top : ndarray of shape (k,) of bool
        True for a string on the top face.

    Returns
    -------
    str
        ``"top"`` when the bottom strings' total weight is at least the top
        strings' (a design without strings included), else ``"bottom"``.

    Examples
    --------
    >>> length_keeping_face([0.3, 0.3, 0.2], [False, False, True])
    'top'
    >>> length_keeping_face([0.3], [True])
    'bottom'
    """
    weights, top = np.asarray(weights, float), np.asarray(top, bool)
    return "top" if weights[~top].sum() >= weights[top].sum() else "bottom"


def strings_named_face(report, share, top) -> str:
    """The face Ŝ stands for, given its strings: the face of Ŝ's metric, else :func:`length_keeping_face`.

    The one rule of the designer (Equation 3's free faces) and of the check (the face compared).

    Parameters
    ----------
    report : airmat.design.constructibility.ConstructibilityReport or None
        Its ``metric["face"]`` names the face Ŝ was relaxed in, when it was.
    share : ndarray of shape (k,)
        Each string's |κ| times its chord on Ω.
    top : ndarray of shape (k,) of bool
        True for a string on the top face.

    Returns
    -------
    str
        ``"top"`` or ``"bottom"``.

    Examples
    --------
    >>> strings_named_face(None, [0.3, 0.1], [True, False])
    'bottom'
    """
    face = None if report is None else report.metric.get("face")
    return face if face in ("top", "bottom") else length_keeping_face(share, top)


def face_metric(xyz, uv, faces, kappa, directions, *, thickness: float, kappa_min: float = 0.25,
                kappa_max: float = np.inf, margin: float = 0.0, face: str | None = None) -> FaceMetric:
    """Rest lengths of Ω's edges on the named face of a mattress bent to Ŝ.

    Parameters
    ----------
    xyz : ndarray of shape (n, 3)
        Ŝ (m).
    uv : ndarray of shape (n, 2)
        Ω (m).
    faces : ndarray of shape (m, 3)
    kappa : ndarray of shape (n, 2)
        Ŝ's signed principal curvatures (1/m), positive bending away from the top face.
    directions : ndarray of shape (n, 2, 3)
        Their unit directions in space.
    thickness : float
        Mattress thickness d (m).
    kappa_min : float
        |κ| (1/m) below which a family needs no string (and shortens nothing).
    kappa_max : float
        The largest |κ| (1/m) a string reaches: larger curvatures (Ŝ beyond reach, or the
        noise of a curvature fit at a rim) shorten the face only as much as that.
    margin : float
        Dashes stay this far inside Ω's edge (m): no string shortens the face closer to it.
    face : {"top", "bottom"}, optional
        The named face; default :func:`named_face`.

    Returns
    -------
    FaceMetric

    Examples
    --------
    A saddle patch bent +3 1/m along x and -1 1/m along y: the top face (opposite
    the +3 strings) carries the -1 strings along y, so y edges shorten by 1 / (1 + 0.07).

    >>> uv = np.array([[0.0, 0.0], [0.02, 0.0], [0.0, 0.02]])
    >>> xyz = np.column_stack([uv, np.zeros(3)])
    >>> k = np.array([[3.0, -1.0]] * 3)
    >>> dirs = np.array([[[1.0, 0, 0], [0, 1.0, 0]]] * 3)
    >>> m = face_metric(xyz, uv, np.array([[0, 1, 2]]), k, dirs, thickness=0.07)
    >>> m.face, np.round(m.ratio, 4).tolist()
    ('top', [1.0, 0.9346, 0.9662])
    """
    xyz, uv, kappa, directions = (np.asarray(a, float) for a in (xyz, uv, kappa, directions))
    faces = np.asarray(faces)
    face = named_face(kappa, uv, faces, kappa_min=kappa_min) if face is None else face
    if face not in ("top", "bottom"):
        raise ValueError(f"face must be 'top' or 'bottom', got {face!r}")
    edges = mesh_edges(faces)
    flat = np.linalg.norm(uv[edges[:, 1]] - uv[edges[:, 0]], axis=1)
    t = xyz[edges[:, 1]] - xyz[edges[:, 0]]
    t /= np.maximum(np.linalg.norm(t, axis=1), 1e-300)[:, None]
    # the named face's own strings bend it with the sign the other face's strings do not
    inside = np.min(np.concatenate([uv - uv.min(axis=0), uv.max(axis=0) - uv], axis=1), axis=1) >= margin
    own = (np.clip(-kappa if face == "top" else kappa, 0.0, kappa_max)
           * ((np.abs(kappa) >= kappa_min) & inside[:, None]))                                     # (n, 2)
    kn = np.zeros(len(edges))
    for end in (0, 1):
        cos2 = np.einsum("kd,kjd->kj", t, directions[edges[:, end]]) ** 2                     # (e, 2)
        kn += 0.5 * np.einsum("kj,kj->k", own[edges[:, end]], cos2)
    ratio = 1.0 / (1.0 + thickness * kn)
    return FaceMetric(face=face, rest=flat * ratio, ratio=ratio)


def relax_in_face_metric(relax, uv, faces, projector, *, thickness: float, kappa_min: float = 0.25,
                         kappa_max: float = np.inf, margin: float = 0.0, rounds: int = ROUNDS,
                         curvature=None, curvature_radius: float = 2.5, k_a1: float = 1.0,
                         k_a2: float = 0.2, k_a3: float = 0.02, tol: float = 1e-4, stall: float = 1e-7,
                         max_iter: int = 1000):
    """Relax Ŝ again in its named face's metric (a few rounds, each from the last).

    Parameters
    ----------
    relax : airmat.design.relax.RelaxResult
        Ŝ relaxed in Ω's metric.
    uv, faces : ndarray
        Ω's triangulation (m).
    projector : airmat.design.closest_point.MeshProjector
        The target S.
    thickness : float
        Mattress thickness d (m).
    kappa_min : float
        |κ| (1/m) below which a family needs no string.
    kappa_max : float
        The largest |κ| (1/m) a string reaches (:func:`face_metric`).
    margin : float
        Dashes stay this far inside Ω's edge (m) (:func:`face_metric`).
    rounds : int
        Relaxations in the metric, each with the metric of the last Ŝ's curvature.
    curvature : airmat.design.curvature.PrincipalCurvature, optional
        Of ``relax.xyz``, if already computed (it is then not computed again).
    curvature_radius : float
        Neighbourhood of the curvature fit (mean edge lengths), as for Ŝ's curvature.
    k_a1, k_a2, k_a3, tol, stall, max_iter
        As in :func:`airmat.design.relax.relax_to_target`.

    Returns
    -------
    relax : airmat.design.relax.RelaxResult
        The input unchanged when the named face keeps Ω's lengths everywhere; else Ŝ
        in the face metric (``n_iter`` adds the rounds' iterations, ``converged`` is
        the last round's, the message says so).
    metric : FaceMetric
        The metric of the returned Ŝ's start (the last round's).
    """
    from airmat.design.curvature import principal_curvature
    from airmat.design.relax import relax_from

    x = relax.xyz
    curv = principal_curvature(x, faces, radius=curvature_radius) if curvature is None else curvature
    metric = face_metric(x, uv, faces, curv.kappa, curv.directions, thickness=thickness, kappa_min=kappa_min,
                         kappa_max=kappa_max, margin=margin)
    if metric.flat:
        return relax, metric
    face = metric.face
    n_iter, converged, residual = relax.n_iter, relax.converged, relax.residual
    for r in range(rounds):
        if r:
            curv = principal_curvature(x, faces, radius=curvature_radius)
            metric = face_metric(x, uv, faces, curv.kappa, curv.directions, thickness=thickness,
                                 kappa_min=kappa_min, kappa_max=kappa_max, margin=margin, face=face)
        x, it, converged, residual, energy = relax_from(x, uv, faces, projector, rest=metric.rest, k_a1=k_a1,
                                                k_a2=k_a2, k_a3=k_a3, tol=tol, stall=stall, max_iter=max_iter)
        n_iter += it
    log.info("Ŝ relaxed in the %s face's metric (%d rounds; its strings shorten it to %.3f of Ω at least)",
             face, rounds, metric.ratio.min())
    closest = projector.closest(x)
    message = (f"{relax.message}; then {rounds} rounds in the {face} face's metric: "
               f"{'converged' if converged else 'not converged'} (largest force {residual:.2g} k_A1·h)")
    # the result is the last round's: a first stage that stopped early but was carried on to convergence
    # is converged (its message still says how the first stage ended)
    return dataclasses.replace(relax, xyz=x, converged=bool(converged), n_iter=int(n_iter),
                               residual=float(residual), message=message, energy=energy,
                               distance={"mean": float(closest.distance.mean()),
                                         "max": float(closest.distance.max())},
                               off_target=np.where(closest.on_rim, closest.distance, 0.0)), metric
