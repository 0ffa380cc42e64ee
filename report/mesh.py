"""Meshes for display: a regular grid on Ω decimated to a vertex budget, as plotly ``mesh3d`` traces.

Ŝ and the inflated mid-surface sampled at Ŝ's vertices share the row-major grid
of :func:`airmat.design.mattress.triangulate_mattress`; :func:`display_grid` keeps
every s-th grid line (and the last) so a large preset stays a few hundred
kilobytes on the page.
"""

from __future__ import annotations

import numpy as np

from airmat.units import M_TO_MM

__all__ = ["display_grid", "grid_image", "mesh3d_trace", "wireframe_trace", "MAX_DISPLAY_VERTICES"]

#: vertex budget of one displayed mesh (about 0.5 MB of JSON each)
MAX_DISPLAY_VERTICES = 12_000


def _grid_shape(uv: np.ndarray):
    """(nu, nv) when ``uv`` is a row-major regular grid (``uv[j * nu + i]``), else None."""
    n = len(uv)
    if n < 4:
        return None
    nu = int(np.argmax(np.diff(uv[:, 0]) < 0)) + 1 if np.any(np.diff(uv[:, 0]) < 0) else n
    if nu < 2 or n % nu:
        return None
    nv = n // nu
    g = uv.reshape(nv, nu, 2)
    if not (np.allclose(g[:, :, 0], g[:1, :, 0]) and np.allclose(g[:, :, 1], g[:, :1, 1])):
        return None
    return nu, nv


def _keep(n: int, step: int) -> np.ndarray:
    idx = np.arange(0, n, step)
    return idx if idx[-1] == n - 1 else np.append(idx, n - 1)


def display_grid(uv, faces, *, max_vertices: int = MAX_DISPLAY_VERTICES):
    """Vertex indices and triangles of a display mesh with at most about ``max_vertices`` vertices.

    Parameters
    ----------
    uv : ndarray of shape (n, 2)
        Ω coordinates (m) of the mesh's vertices.
    faces : ndarray of shape (m, 3)
    max_vertices : int

    Returns
    -------
    keep : ndarray of shape (k,)
        Indices into the original vertices.
    faces : ndarray of shape (f, 3)
        Triangles over ``keep``'s order. The input mesh when it is small enough or not a
        regular grid (then ``keep`` is every vertex).

    Examples
    --------
    >>> u, v = np.meshgrid(np.linspace(0, 1, 101), np.linspace(0, 1, 101))
    >>> uv = np.column_stack([u.ravel(), v.ravel()])
    >>> keep, f = display_grid(uv, np.zeros((0, 3), int), max_vertices=2000)
    >>> len(keep), f.shape
    (1225, (2312, 3))
    """
    uv, faces = np.asarray(uv, float), np.asarray(faces)
    shape = _grid_shape(uv) if len(uv) > max_vertices else None
    if shape is None:
        return np.arange(len(uv)), faces
    nu, nv = shape
    step = int(np.ceil(np.sqrt(len(uv) / max_vertices)))
    iu, jv = _keep(nu, step), _keep(nv, step)
    keep = (jv[:, None] * nu + iu[None, :]).ravel()
    a = (np.arange(len(jv) - 1)[:, None] * len(iu) + np.arange(len(iu) - 1)[None, :]).ravel()
    b, c, d = a + 1, a + len(iu), a + len(iu) + 1
    tri = np.concatenate([np.column_stack([a, b, d]), np.column_stack([a, d, c])])
    return keep, tri


def mesh3d_trace(xyz, faces, *, intensity=None, name: str, color: str | None = None, opacity: float = 1.0,
                 colorscale: str = "Viridis", colorbar_title: str = "", hover: str = "") -> dict:
    """A plotly ``mesh3d`` trace in millimetres (0.1 mm), coloured by ``intensity`` per vertex or one colour.

    Parameters
    ----------
    xyz : ndarray of shape (n, 3)
        Vertices (m).
    faces : ndarray of shape (m, 3)
    intensity : ndarray of shape (n,), optional
        Per-vertex value shown with ``colorscale`` (rounded to 4 significant digits).
    name, color, opacity, colorscale, colorbar_title, hover
        Plotly trace options; ``hover`` is the hover template's value line.
    """
    p = np.round(np.asarray(xyz, float) * M_TO_MM, 1)
    f = np.asarray(faces, np.int64)
    trace = {"type": "mesh3d", "name": name, "x": p[:, 0], "y": p[:, 1], "z": p[:, 2],
             "i": f[:, 0], "j": f[:, 1], "k": f[:, 2], "opacity": opacity, "showlegend": True,
             "flatshading": False, "lighting": {"ambient": 0.6, "diffuse": 0.6, "specular": 0.1}}
    if intensity is not None:
        vals = np.asarray(intensity, float)
        scale = max(float(np.max(np.abs(vals))), 1e-30) if vals.size else 1.0
        digits = max(0, 3 - int(np.floor(np.log10(scale))))
        trace.update(intensity=np.round(vals, digits), colorscale=colorscale,
                     colorbar={"title": {"text": colorbar_title}, "len": 0.7},
                     hovertemplate=f"{hover}<extra>{name}</extra>")
    else:
        trace.update(color=color or "lightgrey", hoverinfo="skip")
    return trace


def grid_image(uv, values, *, max_vertices: int = MAX_DISPLAY_VERTICES):
    """Values on a row-major regular grid on Ω as an image: its axes (mm) and a (rows, columns) array.

    Parameters
    ----------
    uv : ndarray of shape (n, 2)
        Ω coordinates (m) of the grid's vertices.
    values : ndarray of shape (n,)
    max_vertices : int
        Keep every s-th grid line (and the last) to stay under about this many pixels.

    Returns
    -------
    (u_mm, v_mm, image) or None
        ``image[j, i]`` is the value at ``(u_mm[i], v_mm[j])``; None when ``uv`` is not a regular grid.

    Examples
    --------
    >>> u, v = np.meshgrid(np.linspace(0, 0.2, 3), np.linspace(0, 0.1, 2))
    >>> uv = np.column_stack([u.ravel(), v.ravel()])
    >>> grid_image(uv, np.arange(6.0))[2]
    array([[0., 1., 2.],
           [3., 4., 5.]])
    """
    uv, values = np.asarray(uv, float), np.asarray(values, float)
    shape = _grid_shape(uv)
    if shape is None:
        return None
    nu, nv = shape
    step = max(1, int(np.ceil(np.sqrt(len(uv) / max_vertices))))
    iu, jv = _keep(nu, step), _keep(nv, step)
    g = uv.reshape(nv, nu, 2)
    return g[0, iu, 0] * M_TO_MM, g[jv, 0, 1] * M_TO_MM, values.reshape(nv, nu)[np.ix_(jv, iu)]


def wireframe_trace(xyz, uv, faces, *, name: str, color: str, lines: int = 24, width: float = 1.5) -> dict:
    """A plotly ``scatter3d`` wireframe of a mesh (mm): about ``lines`` grid lines each way on a regular grid,
    else every edge of ``faces``.

    A wireframe shows Ŝ beside an opaque surface without the flicker of two coincident
    translucent surfaces (z-fighting).

    Parameters
    ----------
    xyz : ndarray of shape (n, 3)
        Vertices (m).
    uv : ndarray of shape (n, 2)
        Their Ω coordinates (m).
    faces : ndarray of shape (m, 3)
    name, color : str
    lines : int
        Grid lines along each direction on a regular grid.
    width : float
        Line width (px).
    """
    p = np.round(np.asarray(xyz, float) * M_TO_MM, 1)
    shape = _grid_shape(np.asarray(uv, float))
    if shape is not None:
        nu, nv = shape
        g = p.reshape(nv, nu, 3)
        rows = [g[j] for j in _keep(nv, max(1, nv // lines))]
        cols = [g[:, i] for i in _keep(nu, max(1, nu // lines))]
        polylines = rows + cols
    else:
        f = np.asarray(faces, np.int64)
        edges = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1), axis=0)
        polylines = list(p[edges])
    gap = np.full((1, 3), np.nan)
    pts = np.concatenate([np.concatenate([q, gap]) for q in polylines]) if polylines else np.zeros((0, 3))
    coords = {k: [None if np.isnan(c) else float(c) for c in pts[:, n]] for n, k in enumerate("xyz")}
    return {"type": "scatter3d", "mode": "lines", "name": name, **coords, "hoverinfo": "skip",
            "line": {"color": color, "width": width}, "showlegend": True}
