"""The closed double-layer mesh M′ of an air mattress (paper §3.4).

The top and bottom faces are the same structured triangulation of
Ω = [0, W] × [0, H], a thickness d apart (top at z = +d/2, bottom at
z = -d/2), joined along the boundary by one band of side quads, each split
into four triangles around a vertex at its centre (z = 0). ``top[g]`` and
``bottom[g]`` are the two copies of grid point ``g`` and share its Ω
coordinates ``uv[top[g]]``; the side-wall vertices come last.

The grid (:mod:`airmat.geometry.grid`, Ω's grid) has an even number of
cells along each side and its diagonals follow the "union jack" pattern
(each points toward the centre of Ω), so the mesh is exactly symmetric under
both mirrors of the rectangle: a symmetric string pattern then gives a
symmetric inflated shape. (The designer's Ω mesh alternates its diagonals
instead: see that module.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from airmat.errors import InputError
from airmat.geometry.grid import boundary_loop, cell_count, rectangle_grid
from airmat.geometry.topology import mesh_edges

__all__ = ["MattressMesh", "build_mattress_mesh", "grid_shape", "MAX_VERTICES"]

#: Largest mesh the solver accepts (both faces): the Cholesky factor of the
#: Newton system had 25 M non-zeros for 21 642 vertices (large mattress, 20 mm),
#: ~14 kB per vertex with its indices and growing like n log n: 2e5 vertices is
#: ~4 GB, and minutes per factorization.
MAX_VERTICES = 200_000


@dataclass(frozen=True)
class MattressMesh:
    """The closed mesh M′ and its maps to Ω.

    Attributes
    ----------
    width, height, thickness : float
        W, H and d (m).
    vertices : ndarray of shape (n, 3)
        Rest positions (m): Ω in the xy-plane, top at z = +d/2.
    faces : ndarray of shape (m, 3)
        Triangles, outward oriented (the enclosed volume is positive).
    uv : ndarray of shape (n, 2)
        Ω coordinates of every vertex (m); a side-wall vertex has those of
        the middle of its boundary edge.
    top, bottom : ndarray of shape (g,)
        Vertex index of grid point ``g`` on the top and on the bottom face.
    grid_shape : tuple of int
        (nx, ny) grid points along u and v; grid point ``g = j * nx + i``.
    grid_faces : ndarray of shape (t, 3)
        The triangulation of Ω on grid-point indices (CCW seen from above).
    edges : ndarray of shape (e, 2)
        Unique mesh edges (vertex indices).
    """

    width: float
    height: float
    thickness: float
    vertices: np.ndarray
    faces: np.ndarray
    uv: np.ndarray
    top: np.ndarray
    bottom: np.ndarray
    grid_shape: tuple
    grid_faces: np.ndarray
    edges: np.ndarray

    @property
    def spacing(self) -> tuple:
        """Grid spacing (du, dv) on Ω (m)."""
        nx, ny = self.grid_shape
        return self.width / (nx - 1), self.height / (ny - 1)

    @property
    def n_vertices(self) -> int:
        return len(self.vertices)


def grid_shape(width: float, height: float, resolution: float) -> tuple:
    """Grid points (nx, ny) for a target edge length: an even cell count per side, spacing <= resolution."""
    return cell_count(width, resolution, even=True) + 1, cell_count(height, resolution, even=True) + 1


def build_mattress_mesh(width: float, height: float, thickness: float, *,
                        resolution: float = 0.025, max_vertices: int = MAX_VERTICES) -> MattressMesh:
    """Build the closed double-layer mesh M′ of a flat mattress.

    Parameters
    ----------
    width, height : float
        W and H of Ω (m).
    thickness : float
        d, the distance between the top and bottom faces (m).
    resolution : float, keyword-only
        Largest edge length along u and v (m); the grid has an even number
        of cells per side, so the actual spacing is at most this.
    max_vertices : int, keyword-only
        Refuse meshes larger than this (both faces).

    Returns
    -------
    MattressMesh

    Raises
    ------
    airmat.errors.InputError
        For non-positive sizes, or a resolution so fine the mesh would exceed
        ``max_vertices`` (the message gives the estimate and the limit).

    Examples
    --------
    >>> m = build_mattress_mesh(0.8, 0.4, 0.07, resolution=0.1)
    >>> m.grid_shape, m.n_vertices
    ((9, 5), 114)
    """
    import igl  # here, not at the top: 0.6 s that ``import airmat.inflation.mesh`` (the check's locate) need not pay

    for name, x in (("width", width), ("height", height), ("thickness", thickness),
                    ("resolution", resolution)):
        if not (np.isfinite(x) and x > 0):
            raise InputError(f"mattress {name} must be a positive length, got {x!r} m", **{name: x})
    nx, ny = grid_shape(width, height, resolution)
    n_est = 2 * nx * ny + 2 * (nx + ny - 2)
    if n_est > max_vertices:
        raise InputError(f"resolution {resolution * 1e3:.4g} mm is too fine for a {width * 1e3:.0f} x "
                         f"{height * 1e3:.0f} mm mattress: {n_est} vertices, limit {max_vertices} "
                         f"(memory of the sparse solver); use a coarser resolution",
                         n_vertices=n_est, limit=max_vertices)
    ng = nx * ny
    uv_grid, tri = rectangle_grid(width, height, nx, ny, diagonals="union_jack")
    top, bottom = np.arange(ng), ng + np.arange(ng)
    vertices = np.concatenate([np.column_stack([uv_grid, np.full(ng, thickness / 2)]),
                               np.column_stack([uv_grid, np.full(ng, -thickness / 2)])])
    loop = boundary_loop(nx, ny)
    p, q = loop, np.roll(loop, -1)
    # each side-wall quad gets a vertex at its centre and four triangles: the band is then
    # symmetric under both mirrors of Ω and under top <-> bottom, like the faces
    c = 2 * ng + np.arange(len(loop))
    bp, bq, tp, tq = bottom[p], bottom[q], top[p], top[q]
    side = np.concatenate([np.c_[bp, bq, c], np.c_[bq, tq, c], np.c_[tq, tp, c], np.c_[tp, bp, c]])
    uv_side = 0.5 * (uv_grid[p] + uv_grid[q])
    vertices = np.concatenate([vertices, np.column_stack([uv_side, np.zeros(len(loop))])])
    faces = np.concatenate([top[tri], bottom[tri][:, ::-1], side]).astype(np.int64)
    return MattressMesh(width=float(width), height=float(height), thickness=float(thickness),
                        vertices=vertices, faces=faces, uv=np.concatenate([uv_grid, uv_grid, uv_side]),
                        top=top, bottom=bottom, grid_shape=(nx, ny), grid_faces=tri,
                        edges=mesh_edges(faces, by_second=True))


def locate(mesh: MattressMesh, uv) -> tuple:
    """Find the Ω triangle of each point and its barycentric coordinates.

    Parameters
    ----------
    mesh : MattressMesh
    uv : array_like of shape (k, 2)
        Points on Ω (m). Points outside Ω get the nearest boundary cell and
        barycentric coordinates that extrapolate (some negative).

    Returns
    -------
    grid_tri : ndarray of shape (k, 3)
        Grid-point indices of the containing triangle (index ``mesh.top`` or
        ``mesh.bottom`` with them to get vertices).
    bary : ndarray of shape (k, 3)
        Barycentric coordinates, summing to 1.
    """
    from trimesh.triangles import points_to_barycentric

    pts = np.asarray(uv, dtype=float).reshape(-1, 2)
    nx, ny = mesh.grid_shape
    du, dv = mesh.spacing
    i = np.clip(np.floor(pts[:, 0] / du).astype(np.int64), 0, nx - 2)
    j = np.clip(np.floor(pts[:, 1] / dv).astype(np.int64), 0, ny - 2)
    cell = j * (nx - 1) + i
    cand = np.stack([cell, cell + (nx - 1) * (ny - 1)], axis=1)            # the cell's two triangles
    tri = mesh.grid_faces[cand]                                              # (k, 2, 3)
    uv_grid = mesh.uv[mesh.top]
    corners = np.concatenate([uv_grid[tri], np.zeros(tri.shape + (1,))], axis=-1).reshape(-1, 3, 3)
    p3 = np.repeat(np.column_stack([pts, np.zeros(len(pts))]), 2, axis=0)
    bary = points_to_barycentric(corners, p3).reshape(-1, 2, 3)
    best = np.argmax(bary.min(axis=2), axis=1)
    rows = np.arange(len(pts))
    return tri[rows, best], bary[rows, best]
