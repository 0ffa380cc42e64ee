"""Closest points on a triangle mesh through a BVH (open3d's RaycastingScene).

The scene is built once per target and queried once per relaxation
iteration for all vertices at a time. open3d works in float32 (the mesh is
shifted to its bounding-box centre first); it is used only to find the
closest triangle, and the closest point on that triangle is then computed
in float64 (trimesh.triangles.closest_point, vectorized), so distances and
energies are smooth to double precision, which the relaxation's energy
safeguard needs.

S usually ends at a rim (its boundary edges). :meth:`MeshProjector.closest_extended`
continues S across the rim by the tangent plane of the rim face: where
the closest point of S lies on the rim, the point is projected onto that
face's plane instead (the relaxation's A2 then pulls a mattress that
overhangs S only along the rim face's normal, not back onto the rim).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from trimesh.triangles import closest_point as closest_point_on_triangles
from trimesh.triangles import points_to_barycentric

from airmat.cores import idle_cores
from airmat.geometry.topology import boundary_face_flags

__all__ = ["beyond_rim", "BEYOND_RIM", "ClosestPoints", "MeshProjector"]

#: a closest point nearer than this (in mean edge lengths of the mesh) to a rim edge or rim vertex
#: of its triangle is on the rim. Generous on purpose: open3d finds the closest triangle in
#: float32 and among near-ties (feet within ~1e-4 m of an edge) may return a neighbour, so the
#: foot can sit that far beside the rim vertex; and flagging a point inside the rim costs nothing
#: (its foot on its own triangle is its projection onto that triangle's plane).
RIM_TOL = 0.05

#: seconds between two looks at the idle cores by a projector that chose its threads itself: a
#: process that starts (or ends) beside a long relaxation changes them while the projector is in use
RECHECK_SECONDS = 1.0


@dataclass(frozen=True)
class ClosestPoints:
    """Result of a closest-point query for k points.

    Attributes
    ----------
    points : ndarray of shape (k, 3)
        Closest points on the mesh (m).
    face : ndarray of shape (k,)
        Index of the triangle each closest point lies on.
    normal : ndarray of shape (k, 3)
        Unit normal of that triangle (from its winding).
    distance : ndarray of shape (k,)
        Distance (m) from each query point to its closest point.
    on_rim : ndarray of shape (k,), bool
        Whether the closest point of the mesh lies on its boundary (a rim edge or
        rim vertex): the query point is beyond the rim or level with it.
    """

    points: np.ndarray
    face: np.ndarray
    normal: np.ndarray
    distance: np.ndarray
    on_rim: np.ndarray


class MeshProjector:
    """A BVH over a triangle mesh for closest-point and ray queries.

    Parameters
    ----------
    vertices : ndarray of shape (n, 3)
        Mesh vertices (m).
    faces : ndarray of shape (m, 3)
        Triangles.
    threads : int, optional
        Threads per query (0: all cores). Default: the cores other processes leave idle
        (:func:`airmat.cores.idle_cores`), looked at again every ``RECHECK_SECONDS`` while
        the projector is used: on an idle 2-core machine two threads take the dome's
        relaxation from 5.2 to 3.9 s, but on a busy one they are slower (two processes
        relaxing it side by side: 6.9-7.2 s each with two threads, 6.0 s with one). The
        answers do not depend on it.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> proj = MeshProjector(V, np.array([[0, 1, 2]]))
    >>> proj.closest(np.array([[0.2, 0.2, 0.5]])).points.round(6).tolist()
    [[0.2, 0.2, 0.0]]

    Beyond the rim, :meth:`closest_extended` continues the triangle by its plane:

    >>> proj.closest(np.array([[2.0, -0.5, 0.5]])).points.round(6).tolist()
    [[1.0, 0.0, 0.0]]
    >>> proj.closest_extended(np.array([[2.0, -0.5, 0.5]])).points.round(6).tolist()
    [[2.0, -0.5, 0.0]]
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, *, threads: int | None = None):
        from airmat.lazy import import_open3d

        o3d = import_open3d()

        vertices = np.asarray(vertices, dtype=float)
        self._faces = np.asarray(faces, dtype=np.int64)
        self._vertices = vertices
        self._origin = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
        self._scene = o3d.t.geometry.RaycastingScene()
        self._scene.add_triangles(o3d.core.Tensor((vertices - self._origin).astype(np.float32)),
                                  o3d.core.Tensor(self._faces.astype(np.uint32)))
        self._o3d = o3d
        self._auto = threads is None
        self._threads = idle_cores() if self._auto else int(threads)
        self._threads_checked = time.monotonic()
        cross = np.cross(vertices[self._faces[:, 1]] - vertices[self._faces[:, 0]],
                         vertices[self._faces[:, 2]] - vertices[self._faces[:, 0]])
        self._unit_normal = cross / np.maximum(np.linalg.norm(cross, axis=1, keepdims=True), 1e-300)
        self._rim_edge, self._rim_vertex = boundary_face_flags(self._faces, len(vertices))
        self._rim_face = self._rim_edge.any(axis=1) | self._rim_vertex[self._faces].any(axis=1)
        tri = vertices[self._faces]
        self._tri = tri                          # every face's corners (f, 3, 3): one gather per query
        side = np.linalg.norm(tri[:, [2, 0, 1]] - tri[:, [1, 2, 0]], axis=2)   # side opposite corner i
        # altitude onto the side opposite corner i: the distance per unit of barycentric coordinate i
        self._altitude = np.linalg.norm(cross, axis=1)[:, None] / np.maximum(side, 1e-300)
        self._rim_tol = RIM_TOL * float(side.mean())

    @property
    def threads(self) -> int:
        """Threads of the next query: the ones given, or the idle cores (one quick reading each
        ``RECHECK_SECONDS``; one core when the system does not say)."""
        if self._auto and time.monotonic() - self._threads_checked >= RECHECK_SECONDS:
            self._threads = idle_cores(samples=1)
            self._threads_checked = time.monotonic()
        return self._threads

    def closest(self, points: np.ndarray) -> ClosestPoints:
        """Closest points on the mesh to ``points`` (k, 3) (m)."""
        points = np.asarray(points, dtype=float)
        q = self._o3d.core.Tensor((points - self._origin).astype(np.float32))
        ans = self._scene.compute_closest_points(q, nthreads=self.threads)
        face = ans["primitive_ids"].numpy().astype(np.int64)
        bad = (face < 0) | (face >= len(self._faces))   # open3d's invalid id (NaN queries)
        face[bad] = 0
        tri = self._tri[face]
        cp = closest_point_on_triangles(tri, points)
        cp[bad] = np.nan
        return ClosestPoints(points=cp, face=face,
                             normal=ans["primitive_normals"].numpy().astype(float),
                             distance=np.linalg.norm(cp - points, axis=1),
                             on_rim=self._on_rim(tri, face, cp))

    def _on_rim(self, tri, face, cp):
        """Whether each closest point ``cp`` (k, 3) on triangle ``face`` (k,) lies on the mesh's rim.

        Only the points whose face touches the rim (a rim edge or a rim corner) are tested: the
        others cannot be on it, and the test is row by row, so the answer is the same bits."""
        out = np.zeros(len(face), bool)
        near = np.flatnonzero(self._rim_face[face])
        if not len(near):
            return out
        tri, face, cp = tri[near], face[near], cp[near]
        with np.errstate(invalid="ignore", divide="ignore"):
            bary = points_to_barycentric(tri, cp)
        on_edge = (bary * self._altitude[face] < self._rim_tol) & self._rim_edge[face]
        at_vertex = ((np.linalg.norm(tri - cp[:, None], axis=2) < self._rim_tol)
                     & self._rim_vertex[self._faces[face]])
        out[near] = (on_edge | at_vertex).any(axis=1)
        return out

    def closest_extended(self, points: np.ndarray) -> ClosestPoints:
        """Closest points on the mesh continued across its rim by the rim faces' tangent planes.

        Where the closest point of the mesh lies on its rim (``on_rim``), it is replaced by the
        projection of the query point onto the plane of the rim face it lies on; elsewhere it is
        :meth:`closest`'s point. So a point beyond the rim is moved only along that face's
        normal. Continuous across the rim: a point level with the rim edge projects onto it.

        Parameters
        ----------
        points : ndarray of shape (k, 3)
            Query points (m).

        Returns
        -------
        ClosestPoints
            ``points`` the closest points on the extended surface, ``distance`` the distance
            to them (m); ``face``, ``normal`` and ``on_rim`` as from :meth:`closest`.
        """
        points = np.asarray(points, dtype=float)
        near = self.closest(points)
        rim = near.on_rim
        if not rim.any():
            return near
        cp = near.points.copy()
        n = self._unit_normal[near.face[rim]]
        cp[rim] = points[rim] - n * np.einsum("ij,ij->i", points[rim] - near.points[rim], n)[:, None]
        return ClosestPoints(points=cp, face=near.face, normal=near.normal,
                             distance=np.linalg.norm(cp - points, axis=1), on_rim=rim)

    def first_hit(self, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """Distance along each ray to the first hit (inf on a miss), shape (k,).

        Parameters
        ----------
        origins, directions : ndarray of shape (k, 3)
            Ray origins (m) and unit directions.
        """
        rays = np.concatenate([np.asarray(origins, float) - self._origin,
                               np.asarray(directions, float)], axis=1).astype(np.float32)
        ans = self._scene.cast_rays(self._o3d.core.Tensor(rays), nthreads=self.threads)
        return ans["t_hit"].numpy().astype(float)


#: a point whose closest point on a target lies on its rim is beyond the rim when it is offset across the target's
#: normal there by more than this share of the diagonal the distances are judged against (1 mm on 1 m)
BEYOND_RIM = 1e-3


def beyond_rim(points: np.ndarray, near: ClosestPoints, tolerance: float) -> np.ndarray:
    """Which ``points`` lie beyond the mesh's rim, shape (k,) bool: their closest point ``near`` is on the rim
    and they are offset across the mesh's normal there by more than ``tolerance`` (m).

    Level with the rim, or straight above or below it, a point is not beyond it. Where a target is smaller
    than the mattress, or has a hole, the points beyond its rim are where it says nothing.

    Parameters
    ----------
    points : ndarray of shape (k, 3)
        Query points (m).
    near : ClosestPoints
        :meth:`MeshProjector.closest` of ``points``.
    tolerance : float
        Offset across the normal (m) below which a point at the rim counts as level with it.
    """
    points = np.asarray(points, dtype=float)
    along = np.einsum("ij,ij->i", points - near.points, near.normal)
    aside = np.sqrt(np.maximum(near.distance ** 2 - along ** 2, 0.0))
    return np.asarray(near.on_rim, bool) & (aside > tolerance)

