"""Is Ŝ constructible? The Table-1 figures of the paper and a verdict that says where.

σ is the ratio of an edge's length on Ŝ to its length on Ω (1: the membrane
is neither stretched nor compressed). Ŝ is declared unconstructible when
some σ leaves the tolerance band (the mattress cannot stretch, and can
contract only a little) or some |κ| exceeds what a string can produce with
the calibration (Equation 3 at l = 0: :func:`airmat.calib.model.kappa_max`).
Part of Ω lying beyond the target's rim (a target that does not cover the
mattress; Ŝ continues S by its tangent plane there) is reported as a
warning, not a reason: the mattress can make that Ŝ, it is just not all S.
Locations are given in millimetres on Ω. Units: m and 1/m inside.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from airmat.errors import InputError
from airmat.geometry.topology import flat_vertex_areas, mesh_edges
from airmat.design.relax import OFF_TARGET

__all__ = ["ConstructibilityReport", "constructibility", "edge_sigma", "PAPER_KAPPA_MAX", "FOLD_SHARE_MAX"]


def _paper_kappa_max() -> float:
    from airmat.constants import PAPER_D, PAPER_DELTA, PAPER_L
    from airmat.calib.model import kappa_max

    return float(kappa_max(PAPER_L, PAPER_DELTA, PAPER_D))


#: largest curvature (1/m) a string reaches with the paper's calibration (L 300, Δ 18, d 70 mm)
PAPER_KAPPA_MAX = _paper_kappa_max()

#: largest share of Ω's area a folded Ŝ's folds may take: beyond it the curvature is a shape, not folds
FOLD_SHARE_MAX = 0.10


@dataclass(frozen=True)
class ConstructibilityReport:
    """Table-1 figures of Ŝ and the verdict.

    Attributes
    ----------
    sigma : dict
        ``min``, ``avg``, ``max`` of the edge length ratio Ŝ / Ω.
    kappa1, kappa2 : dict
        ``avg`` (area-weighted over Ω) and ``max`` of |κ1| and |κ2| (1/m).
    constructible : bool
    reasons : list of str
        Why not, with where (mm on Ω); empty when constructible.
    sigma_band : tuple of float
        The tolerance band used for σ.
    kappa_max : float
        The reachable curvature used (1/m).
    off_target : dict
        ``share``: the share of Ω's area lying beyond S's rim (vertices further than
        0.1 mean edge lengths beyond it), and ``max``: the largest distance (m) of a vertex
        of Ŝ beyond the rim; both 0 when S covers the mattress (or nothing was given).
    warnings : list of str
        What the verdict does not count but a designer should know (Ω off S), with where.
    metric : dict
        The lengths σ is measured against: ``face`` (``"top"`` / ``"bottom"``: the named
        face's metric, airmat.design.face_metric; ``"flat"``: Ω's) and ``min_ratio``, the
        shortest rest length of that metric over Ω's (1 for Ω's own).
    folds : dict or None
        A folded Ŝ (:mod:`airmat.design.fold_route`): ``vertices`` (how many) and ``share`` (of
        Ω's area) of the folds, the vertices whose |κ| exceeds the reachable curvature, and Ŝ's
        largest |κ| ``kappa_max`` (1/m): the mattress gathers there by itself, so they are no
        reason while their share is at most FOLD_SHARE_MAX. None: Ŝ is not folded.
    """

    sigma: dict
    kappa1: dict
    kappa2: dict
    constructible: bool
    reasons: list = field(default_factory=list)
    sigma_band: tuple = (0.9, 1.1)
    kappa_max: float = PAPER_KAPPA_MAX
    off_target: dict = field(default_factory=lambda: {"share": 0.0, "max": 0.0})
    warnings: list = field(default_factory=list)
    metric: dict = field(default_factory=lambda: {"face": "flat", "min_ratio": 1.0})
    folds: dict | None = None

    def table_row(self) -> str:
        """``σ min/avg/max | |κ1| avg // max | |κ2| avg // max`` as one Markdown table row body."""
        s, k1, k2 = self.sigma, self.kappa1, self.kappa2
        return (f"{s['min']:.4f} / {s['avg']:.4f} / {s['max']:.4f} | {k1['avg']:.2f} // {k1['max']:.2f} | "
                f"{k2['avg']:.2f} // {k2['max']:.2f}")


def edge_sigma(xyz, uv, faces, rest=None):
    """Edges (e, 2) and their length ratio σ = |edge on Ŝ| / rest length, shape (e,).

    ``rest`` (e,): the rest lengths (m) of ``mesh_edges(faces)``; default their lengths on Ω.
    """
    edges = mesh_edges(np.asarray(faces))
    num = np.linalg.norm(xyz[edges[:, 0]] - xyz[edges[:, 1]], axis=1)
    den = np.linalg.norm(uv[edges[:, 0]] - uv[edges[:, 1]], axis=1) if rest is None else np.asarray(rest, float)
    return edges, num / den


def _where(points_mm):
    x, y = np.round(points_mm).astype(int)
    return f"({x}, {y}) mm on Ω"


def constructibility(xyz, uv, faces, kappa, *, sigma_band=(0.9, 1.1),
                     kappa_max: float | None = None, off_target=None, metric=None,
                     folds: bool = False) -> ConstructibilityReport:
    """Table-1 figures of Ŝ and whether the mattress can make it.

    Parameters
    ----------
    xyz : ndarray of shape (n, 3)
        Vertices of Ŝ (m).
    uv : ndarray of shape (n, 2)
        The same vertices on Ω (m).
    faces : ndarray of shape (m, 3)
    kappa : ndarray of shape (n, 2)
        Signed principal curvatures (1/m), column 0 the larger magnitude.
    sigma_band : (float, float), default (0.9, 1.1)
        Tolerated σ. The paper's built shapes have σ down to 0.934 (Table 1), and
        U_A1 is symmetric, so Ŝ spreads a strain over stretch and contraction alike:
        a band that refuses any stretch (say (0.9, 1.02)) would reject the paper's
        own saddle. Tighten it when the membrane is known not to stretch.
    kappa_max : float, optional
        Reachable curvature (1/m); default the paper's calibration, 15.66 1/m.
    off_target : ndarray of shape (n,), optional
        Distance (m) of each vertex of Ŝ beyond S's rim, 0 on S
        (airmat.design.relax.RelaxResult.off_target); reported as a warning.
    metric : airmat.design.face_metric.FaceMetric, optional
        Measure σ against the named face's rest lengths instead of Ω's: where that face
        carries strings they shorten it, which is not a contraction the membrane must make.
    folds : bool, default False
        Ŝ is folded (:mod:`airmat.design.fold_route`): the vertices whose |κ| exceeds
        ``kappa_max`` are its folds, where the mattress buckles by itself, and are reported as
        such instead of as a reason while they take at most FOLD_SHARE_MAX of Ω's area.

    Returns
    -------
    ConstructibilityReport
    """
    xyz, uv, faces, kappa = (np.asarray(a) for a in (xyz, uv, faces, kappa))
    kappa_max = PAPER_KAPPA_MAX if kappa_max is None else float(kappa_max)
    lo, hi = sigma_band
    flat = metric is None or metric.flat
    edges, sig = edge_sigma(xyz, uv, faces, None if flat else metric.rest)
    mid_mm = 500.0 * (uv[edges[:, 0]] + uv[edges[:, 1]])
    area = flat_vertex_areas(uv, faces)
    absk = np.abs(kappa)
    reasons = []
    for bad, worst, word in ((sig < lo, np.argmin(sig), f"below {lo:g}"),
                             (sig > hi, np.argmax(sig), f"above {hi:g}")):
        if bad.any():
            reasons.append(f"σ = {sig[worst]:.3f} at {_where(mid_mm[worst])} "
                           f"({int(bad.sum())} of {len(sig)} edges {word}: the mattress cannot "
                           f"{'contract' if word.startswith('below') else 'stretch'} that much)")
    over = absk.max(axis=1) > kappa_max
    share = float(area @ over / area.sum())
    i = int(np.argmax(absk.max(axis=1)))
    fold = {"vertices": int(over.sum()), "share": share, "kappa_max": float(absk[i].max())} if folds else None
    off, warnings = _off_target(off_target, uv, edges, area)
    if over.any():
        where = (f"|κ| = {absk[i].max():.1f} 1/m at {_where(1e3 * uv[i])} exceeds the reachable "
                 f"{kappa_max:.2f} 1/m ({int(over.sum())} of {len(uv)} vertices")
        if folds and share <= FOLD_SHARE_MAX:
            warnings.append(f"drape-like folds on {100 * share:.1f} % of Ω: {where}); no string makes that, the "
                            f"mattress gathers there by buckling")
        else:
            reasons.append(where + (f", {100 * share:.0f} % of Ω: too much for folds, at most "
                                    f"{100 * FOLD_SHARE_MAX:.0f} %)" if folds else ")"))
    return ConstructibilityReport(
        sigma={"min": float(sig.min()), "avg": float(sig.mean()), "max": float(sig.max())},
        kappa1={"avg": float(area @ absk[:, 0] / area.sum()), "max": float(absk[:, 0].max())},
        kappa2={"avg": float(area @ absk[:, 1] / area.sum()), "max": float(absk[:, 1].max())},
        constructible=not reasons, reasons=reasons, sigma_band=(float(lo), float(hi)),
        kappa_max=kappa_max, off_target=off, warnings=warnings,
        metric={"face": "flat", "min_ratio": 1.0} if flat else metric.summary(), folds=fold)


def _off_target(dist, uv, edges, area):
    """Share of Ω's area beyond S's rim, the largest distance (m) beyond it, and the warning."""
    if dist is None:
        return {"share": 0.0, "max": 0.0}, []
    dist = np.asarray(dist, dtype=float)
    if dist.shape != (len(uv),):
        raise InputError(f"off_target has shape {dist.shape}, expected ({len(uv)},)")
    h = np.linalg.norm(uv[edges[:, 0]] - uv[edges[:, 1]], axis=1).mean()
    off = dist > OFF_TARGET * h
    if not off.any():
        return {"share": 0.0, "max": 0.0}, []
    share, i = float(area @ off / area.sum()), int(np.argmax(dist))
    return {"share": share, "max": float(dist[i])}, [
        f"{100 * share:.1f} % of Ω lies beyond the target's rim, up to {1e3 * dist[i]:.0f} mm at "
        f"{_where(1e3 * uv[i])} ({int(off.sum())} of {len(uv)} vertices): Ŝ continues the target "
        f"by its tangent plane there"]
