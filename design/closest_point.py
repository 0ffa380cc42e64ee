"""Closest points on a triangle mesh through a BVH (open3d's RaycastingScene).

The scene is built once per target and queried once per relaxation
iteration for all vertices at a time. open3d works in float32 (the mesh is
shifted to its bounding-box centre first); it is used only to find the
closest triangle, and the closest point on that triangle is then computed
in float64 (trimesh.triangles.closest_point, vectorized), so distances and
energies are smooth to double precision, which the relaxation's energy
safeguard needs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from trimesh.triangles import closest_point as closest_point_on_triangles

__all__ = ["ClosestPoints", "MeshProjector"]


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
    """

    points: np.ndarray
    face: np.ndarray
    normal: np.ndarray
    distance: np.ndarray


class MeshProjector:
    """A BVH over a triangle mesh for closest-point and ray queries.

    Parameters
    ----------
    vertices : ndarray of shape (n, 3)
        Mesh vertices (m).
    faces : ndarray of shape (m, 3)
        Triangles.
    threads : int, default 1
        Threads per query (0: all cores). One thread: a relaxation query is only a few
        thousand points, and on a busy 2-core machine more threads were 2-3× slower.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> proj = MeshProjector(V, np.array([[0, 1, 2]]))
    >>> proj.closest(np.array([[0.2, 0.2, 0.5]])).points.round(6).tolist()
    [[0.2, 0.2, 0.0]]
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, *, threads: int = 1):
        import open3d as o3d

        vertices = np.asarray(vertices, dtype=float)
        self._faces = np.asarray(faces, dtype=np.int64)
        self._vertices = vertices
        self._origin = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
        self._scene = o3d.t.geometry.RaycastingScene()
        self._scene.add_triangles(o3d.core.Tensor((vertices - self._origin).astype(np.float32)),
                                  o3d.core.Tensor(self._faces.astype(np.uint32)))
        self._o3d = o3d
        self._threads = int(threads)

    def closest(self, points: np.ndarray) -> ClosestPoints:
        """Closest points on the mesh to ``points`` (k, 3) (m)."""
        points = np.asarray(points, dtype=float)
        q = self._o3d.core.Tensor((points - self._origin).astype(np.float32))
        ans = self._scene.compute_closest_points(q, nthreads=self._threads)
        face = ans["primitive_ids"].numpy().astype(np.int64)
        bad = (face < 0) | (face >= len(self._faces))   # open3d's invalid id (NaN queries)
        face[bad] = 0
        cp = closest_point_on_triangles(self._vertices[self._faces[face]], points)
        cp[bad] = np.nan
        return ClosestPoints(points=cp, face=face,
                             normal=ans["primitive_normals"].numpy().astype(float),
                             distance=np.linalg.norm(cp - points, axis=1))

    def first_hit(self, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """Distance along each ray to the first hit (inf on a miss), shape (k,).

        Parameters
        ----------
        origins, directions : ndarray of shape (k, 3)
            Ray origins (m) and unit directions.
        """
        rays = np.concatenate([np.asarray(origins, float) - self._origin,
                               np.asarray(directions, float)], axis=1).astype(np.float32)
        ans = self._scene.cast_rays(self._o3d.core.Tensor(rays), nthreads=self._threads)
        return ans["t_hit"].numpy().astype(float)
