"""The structured triangulation of a rectangle: one grid for Ω, two diagonal patterns.

The grid of ``nx × ny`` points over [0, W] × [0, H] is row-major (grid point
``g = j * nx + i``). Cell (i, j) is split into two counter-clockwise
triangles (normal +z) along one of its diagonals; face ``c`` and face
``c + (nx - 1)(ny - 1)`` are the two halves of cell ``c = j (nx - 1) + i``.
The two users pick different diagonals, and the choice changes their results:

- ``"alternating"`` (the designer, :func:`airmat.design.mattress.triangulate_mattress`):
  the diagonal alternates like a chequerboard, so the mesh has no preferred
  diagonal direction and every interior vertex's neighbours are centrally
  symmetric: the U_A3 umbrella term vanishes on the flat Ω and Ŝ is not
  biased along one diagonal. Any cell count works (the designer's is
  ``ceil(W / spacing)``, often odd: then the mesh is not mirror-symmetric,
  which the designer does not need).
- ``"union_jack"`` (the simulator, :func:`airmat.inflation.mesh.build_mattress_mesh`):
  every diagonal points toward the centre of Ω, so with an even number of
  cells per side the mesh is exactly symmetric under both mirrors of the
  rectangle and a symmetric string pattern inflates to a symmetric shape.
  (An alternating grid with even counts is mirror-symmetric too, but it is a
  different mesh: the simulator's results, and its tests' tolerances, are
  those of the union jack.)

Lengths in metres (any unit works: nothing here has a scale).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["DIAGONALS", "cell_count", "grid_points", "grid_faces", "rectangle_grid", "boundary_loop",
           "parametric_mesh"]

#: the diagonal patterns of :func:`grid_faces`
DIAGONALS = ("alternating", "union_jack")


def cell_count(length: float, spacing: float, *, even: bool = False) -> int:
    """Cells along a side so that their size is at most ``spacing``.

    Parameters
    ----------
    length, spacing : float
        Side length and largest cell size (m), both > 0.
    even : bool, default False
        Round up to an even count, at least 2 (the union-jack grid's mirror symmetry).

    Examples
    --------
    >>> cell_count(0.83, 0.02), cell_count(0.83, 0.02, even=True), cell_count(0.1, 1.0, even=True)
    (42, 42, 2)
    """
    if even:
        return max(2, 2 * math.ceil(length / (2.0 * spacing) - 1e-9))
    return math.ceil(length / spacing - 1e-9)


def grid_points(width: float, height: float, nx: int, ny: int) -> np.ndarray:
    """Grid points (nx × ny, 2) of [0, W] × [0, H] (m), row-major: row ``j * nx + i`` is point (i, j)."""
    u, v = np.meshgrid(np.linspace(0.0, width, nx), np.linspace(0.0, height, ny), indexing="xy")
    return np.column_stack([u.ravel(), v.ravel()])


def grid_faces(nx: int, ny: int, *, diagonals: str) -> np.ndarray:
    """Triangles of an nx × ny point grid, counter-clockwise seen from above.

    Parameters
    ----------
    nx, ny : int
        Grid points along u and v (>= 2 each).
    diagonals : {"alternating", "union_jack"}
        The diagonal of each cell (module docstring: why each user picks its own).

    Returns
    -------
    ndarray of shape (2 (nx - 1)(ny - 1), 3), int64
        Grid-point indices; face c and c + (nx - 1)(ny - 1) split cell c.

    Examples
    --------
    >>> grid_faces(3, 2, diagonals="alternating").tolist()
    [[0, 1, 4], [1, 2, 4], [0, 4, 3], [2, 5, 4]]
    """
    if diagonals not in DIAGONALS:
        raise ValueError(f"diagonals must be one of {DIAGONALS}, got {diagonals!r}")
    i, j = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), indexing="xy")
    i, j = i.ravel(), j.ravel()
    a = j * nx + i            # (i, j)
    b = a + 1                 # (i+1, j)
    c = a + nx + 1            # (i+1, j+1)
    d = a + nx                # (i, j+1)
    if diagonals == "alternating":
        main = (i + j) % 2 == 0
    else:  # each diagonal points toward the centre of the rectangle
        main = np.sign(i + 0.5 - (nx - 1) / 2.0) * np.sign(j + 0.5 - (ny - 1) / 2.0) > 0
    # main cells: diagonal a-c; the others: diagonal b-d; both counter-clockwise
    t1 = np.where(main[:, None], np.column_stack([a, b, c]), np.column_stack([a, b, d]))
    t2 = np.where(main[:, None], np.column_stack([a, c, d]), np.column_stack([b, c, d]))
    return np.concatenate([t1, t2]).astype(np.int64)


def rectangle_grid(width: float, height: float, nx: int, ny: int, *, diagonals: str):
    """Points and triangles of the rectangle [0, W] × [0, H] on an nx × ny grid.

    Returns
    -------
    uv : ndarray of shape (nx * ny, 2)
        :func:`grid_points` (m).
    faces : ndarray of shape (2 (nx - 1)(ny - 1), 3)
        :func:`grid_faces`.

    Examples
    --------
    >>> uv, faces = rectangle_grid(0.8, 0.4, 9, 5, diagonals="union_jack")
    >>> uv.shape, faces.shape, uv[-1].tolist()
    ((45, 2), (64, 3), [0.8, 0.4])
    """
    return grid_points(width, height, nx, ny), grid_faces(nx, ny, diagonals=diagonals)


def boundary_loop(nx: int, ny: int) -> np.ndarray:
    """Grid indices of the rectangle's boundary, counter-clockwise seen from above, without repetition.

    Examples
    --------
    >>> boundary_loop(3, 2).tolist()
    [0, 1, 2, 5, 4, 3]
    """
    ii = np.arange(nx)
    jj = np.arange(ny)
    return np.concatenate([ii[:-1],                        # v = 0, u increasing
                           jj[:-1] * nx + nx - 1,          # u = W, v increasing
                           (ny - 1) * nx + ii[::-1][:-1],  # v = H, u decreasing
                           jj[::-1][:-1] * nx])            # u = 0, v decreasing


def parametric_mesh(fn, s_range, t_range, *, spacing: float):
    """Mesh the surface ``fn(s, t) -> (k, 3)`` over a parameter rectangle.

    The parameter grid has ``cell_count(s1 - s0, spacing)`` × ``cell_count(t1 - t0, spacing)``
    cells with alternating diagonals (Ω's triangulation), counter-clockwise in
    (s, t), so the normals point along X_s × X_t.

    Parameters
    ----------
    fn : callable
        ``fn(s, t)`` with s, t of shape (k,) returns the points (k, 3) (m).
    s_range, t_range : tuple of float
        (s0, s1) and (t0, t1), parameter units.
    spacing : float
        Largest grid spacing in parameter units.

    Returns
    -------
    vertices : ndarray of shape (n, 3)
    faces : ndarray of shape (m, 3), int64

    Examples
    --------
    >>> v, f = parametric_mesh(lambda s, t: np.column_stack([s, t, s * t]), (-1, 1), (0, 1), spacing=0.5)
    >>> v.shape, f.shape, v[-1].tolist()
    ((15, 3), (16, 3), [1.0, 1.0, 1.0])
    """
    (s0, s1), (t0, t1) = s_range, t_range
    width, height = s1 - s0, t1 - t0
    nx, ny = cell_count(width, spacing) + 1, cell_count(height, spacing) + 1
    st, faces = rectangle_grid(width, height, nx, ny, diagonals="alternating")
    return fn(st[:, 0] + s0, st[:, 1] + t0), faces
