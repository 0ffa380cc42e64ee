"""Distance of points from the user's target S, and which of them lie over S rather than beyond its rim.

Each point's distance to the closest point of S's mesh
(:class:`airmat.design.closest_point.MeshProjector`), as a percentage of a given diagonal (Ŝ's), for Ŝ
itself (design.json) and for an inflated face aligned to Ŝ (:mod:`airmat.check.compare`). Where S is
smaller than the mattress or has a hole, the points beyond its rim are measured to the rim, where S says
nothing; :func:`airmat.design.closest_point.beyond_rim` tells them apart, and the distance over S is given
beside the whole. SI units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from airmat.errors import InputError
from airmat.summary import Summarized, mm

__all__ = ["TargetDistance", "distance_to_target"]


@dataclass(frozen=True, repr=False)
class TargetDistance(Summarized):
    """Distance of points (an aligned inflated face, or Ŝ) from the target S's mesh.

    Attributes
    ----------
    rms, max : float
        RMS and largest distance to the closest points of S (m).
    rms_pct_diag : float
        ``rms`` as a percentage of the diagonal given (Ŝ's bounding box, as for :class:`Deviation`).
    per_vertex : ndarray of shape (n,)
        Each point's distance to S (m).
    over : ndarray of shape (n,) of bool, optional
        Points over S: their closest point lies inside S, not on its rim. The others lie beyond S's rim
        (a target smaller than the mattress, a hole in it), where S says nothing and their distance is to the
        rim. Default: every point.
    diagonal : float
        The length (m) the percentages are of (nan when not known).
    """

    rms: float
    max: float
    rms_pct_diag: float
    per_vertex: np.ndarray
    over: np.ndarray | None = None
    diagonal: float = float("nan")

    @property
    def over_share(self) -> float:
        """Share of the points that lie over S (0..1)."""
        return 1.0 if self.over is None else float(np.mean(self.over))

    @property
    def over_rms(self) -> float:
        """RMS distance (m) of the points over S (nan when none is)."""
        d = self.per_vertex if self.over is None else self.per_vertex[self.over]
        return float(np.sqrt(np.mean(d ** 2))) if d.size else float("nan")

    @property
    def over_max(self) -> float:
        """Largest distance (m) of the points over S (nan when none is)."""
        d = self.per_vertex if self.over is None else self.per_vertex[self.over]
        return float(d.max()) if d.size else float("nan")

    def summary_mm(self) -> dict:
        """The numbers files carry: RMS and max (mm), RMS in % of the diagonal, and ``over_target`` with the
        same over the points over S and their share, when some points are."""
        doc = {"rms_mm": round(self.rms * 1e3, 3), "max_mm": round(self.max * 1e3, 3),
               "rms_pct_diag": round(self.rms_pct_diag, 4)}
        if self.over is not None and self.over.any():
            doc["over_target"] = {"share": round(self.over_share, 4), "rms_mm": round(self.over_rms * 1e3, 3),
                                  "max_mm": round(self.over_max * 1e3, 3),
                                  "rms_pct_diag": round(100.0 * self.over_rms / self.diagonal, 4)}
        return doc

    def _summary(self):
        rows = [("RMS", mm(self.rms)), ("max", mm(self.max)), ("% of the diagonal", f"{self.rms_pct_diag:.2f}")]
        if self.over_share < 1.0:
            rows.append(("over S", f"{100 * self.over_share:.0f} % of the points, RMS {mm(self.over_rms)}"))
        return "TargetDistance", rows


def distance_to_target(points, target, *, diagonal: float, projector=None) -> TargetDistance:
    """Distance of ``points`` from the target surface S (closest points on its mesh, its rim included), and
    which points lie over S (their closest point inside it, not on its rim).

    Parameters
    ----------
    points : ndarray of shape (n, 3)
        E.g. ``Deviation.aligned`` (the inflated face in Ŝ's frame, which is S's frame) or Ŝ's vertices (m).
    target : airmat.design.target.Target or mesh
        S: ``vertices`` (m) and ``faces``.
    diagonal : float
        Length (m) the percentage is of (Ŝ's bounding-box diagonal).
    projector : airmat.design.closest_point.MeshProjector, optional
        A projector already built on S (several point sets against one target).

    Returns
    -------
    TargetDistance

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> square = SimpleNamespace(vertices=np.array([[0., 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]),
    ...                          faces=np.array([[0, 1, 2], [0, 2, 3]]))
    >>> d = distance_to_target(np.array([[0.5, 0.5, 0.1], [0.5, 0.5, -0.3], [1.5, 0.5, 0.0]]), square, diagonal=1.0)
    >>> round(d.max, 6), round(d.over_share, 3), round(d.over_rms, 6)      # the third point lies beyond the rim
    (0.5, 0.667, 0.223607)
    """
    from airmat.design.closest_point import BEYOND_RIM, MeshProjector, beyond_rim

    pts = np.asarray(points, float)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"points have shape {pts.shape}, expected (n, 3)")
    if projector is None:
        projector = MeshProjector(np.asarray(target.vertices, float), np.asarray(target.faces))
    near = projector.closest(pts)
    dist = near.distance
    rms = float(np.sqrt(np.mean(dist ** 2)))
    beyond = beyond_rim(pts, near, BEYOND_RIM * float(diagonal))
    return TargetDistance(rms=rms, max=float(dist.max()), rms_pct_diag=100.0 * rms / float(diagonal),
                          per_vertex=dist, over=~beyond, diagonal=float(diagonal))
