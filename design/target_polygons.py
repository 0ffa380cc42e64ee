"""A target's quads as triangles, where the diagonal does not matter; its larger polygons refused.

A quad can be split along either diagonal, and where it is warped the two choices are different
surfaces, so the designer asks for the triangulation the user means. A modeller's quads (Rhino's
meshes and their OBJ export keep them) are flat to within a small fraction of their size wherever
the mesh is fine enough to carry the surface's curvature: there the choice moves the surface by
less than that fraction. So a quad whose fourth corner lies within :data:`QUAD_WARP` of its longer
diagonal from the plane of the other three is split along its shorter diagonal; a more warped quad,
or a polygon of five corners or more, is refused, saying so.

The polygons come from the file itself: an OBJ's ``f`` lines (:func:`obj_polygons`, with its ``v``
lines, so that the indices are the file's own), an OFF's lines (:func:`off_polygons`), a PLY's face
list as trimesh keeps it (:func:`ply_polygons`), a Rhino mesh's faces (:mod:`airmat.design.target_3dm`).
"""

from __future__ import annotations

import re

import numpy as np

from airmat.errors import InputError

__all__ = ["split_quads", "triangulated", "obj_polygons", "off_polygons", "ply_polygons", "QUAD_WARP"]

#: a quad is split when its fourth corner lies within this fraction of its longer diagonal from the plane
#: of the other three
QUAD_WARP = 0.01

_V = re.compile(rb"(?m)^[ \t]*v[ \t]+(\S+)[ \t]+(\S+)[ \t]+(\S+)")
_F = re.compile(rb"(?m)^[ \t]*f[ \t]+([^\n#]*)")


def split_quads(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Faces (m, 4), a triangle repeating its third corner (Rhino's layout), as triangles (m', 3).

    Each quad is split along its shorter diagonal.

    Parameters
    ----------
    vertices : ndarray of shape (n, 3)
    faces : ndarray of shape (m, 4) of int

    Returns
    -------
    ndarray of shape (m', 3) of int
        The triangles, then the halves of the quads, each with the quad's winding.

    Raises
    ------
    airmat.errors.InputError
        A quad whose fourth corner lies more than :data:`QUAD_WARP` of its longer diagonal from the
        plane of the other three (``n_warped``, ``warp``: the largest such ratio).

    Examples
    --------
    >>> v = np.array([[0.0, 0, 0], [1, 0, 0], [1, 2, 0], [0, 1, 0], [2, 0, 0]])
    >>> split_quads(v, np.array([[0, 1, 2, 3], [1, 4, 2, 2]])).tolist()      # diagonal 0-2 is the longer
    [[1, 4, 2], [0, 1, 3], [1, 2, 3]]
    """
    f = np.asarray(faces, np.int64).reshape(-1, 4)
    v = np.asarray(vertices, float)
    quad = f[:, 2] != f[:, 3]
    tri, q = f[~quad, :3], f[quad]
    if not len(q):
        return tri
    p = v[q]
    d02 = np.linalg.norm(p[:, 2] - p[:, 0], axis=1)
    d13 = np.linalg.norm(p[:, 3] - p[:, 1], axis=1)
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    size = np.linalg.norm(n, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        warp = np.abs(np.einsum("ij,ij->i", p[:, 3] - p[:, 0], n)) / size / np.maximum(d02, d13)
    warp = np.where(size > 0, warp, 0.0)
    bad = warp > QUAD_WARP
    if bad.any():
        raise InputError(f"{int(bad.sum())} of {len(q)} quads are warped (a corner up to {100 * warp.max():.2g} % of "
                         "the quad's diagonal off the plane of the other three), so either diagonal makes another "
                         "surface: mesh it finer, or triangulate it the way you mean (e.g. Rhino: _TriangulateMesh; "
                         "Blender: Triangulate Faces)", n_warped=int(bad.sum()), warp=float(warp.max()))
    short02 = d02 <= d13
    halves = np.where(short02[:, None, None],
                      np.stack([q[:, [0, 1, 2]], q[:, [0, 2, 3]]], axis=1),
                      np.stack([q[:, [0, 1, 3]], q[:, [1, 2, 3]]], axis=1))
    return np.concatenate([tri, halves.reshape(-1, 3)])


def triangulated(vertices: np.ndarray, polygons) -> np.ndarray:
    """Polygons (sequences of vertex indices) as triangles (m, 3): quads by :func:`split_quads`.

    Raises
    ------
    airmat.errors.InputError
        A polygon of fewer than three or more than four corners (``n_polygons``, ``corners``), or a warped quad.
    """
    sizes = np.array([len(p) for p in polygons], np.int64)
    odd = (sizes < 3) | (sizes > 4)
    if odd.any():
        raise InputError(f"the mesh has {int(odd.sum())} faces of {int(sizes[odd].max())} corners (or fewer than three): "
                         "triangulate it first (e.g. Rhino: _TriangulateMesh; Blender: Triangulate Faces)",
                         n_polygons=int(odd.sum()), corners=int(sizes[odd].max()))
    faces = np.empty((len(sizes), 4), np.int64)
    for k in (3, 4):
        rows = np.flatnonzero(sizes == k)
        if len(rows):
            block = np.array([polygons[i] for i in rows], np.int64).reshape(-1, k)
            faces[rows] = block if k == 4 else block[:, [0, 1, 2, 2]]
    return split_quads(vertices, faces)


def obj_polygons(data: bytes) -> tuple:
    """An OBJ's vertices (n, 3) and its faces as polygons of 0-based vertex indices, as the file numbers them.

    Only ``v`` and ``f`` lines are read (texture and normal indices after ``/`` are left out); a relative
    (negative) index counts back from the vertices listed before its face.
    """
    vertices = np.array(_V.findall(data), dtype="S").astype(float).reshape(-1, 3)
    faces = [(m.start(), np.array([int(tok.split(b"/")[0]) for tok in m.group(1).split()], np.int64))
             for m in _F.finditer(data)]
    if not any((idx < 0).any() for _, idx in faces):
        return vertices, [idx - 1 for _, idx in faces]
    starts = np.array([m.start() for m in _V.finditer(data)], np.int64)
    before = np.searchsorted(starts, [at for at, _ in faces])           # vertices listed before each face
    return vertices, [np.where(idx < 0, b + idx, idx - 1) for (_, idx), b in zip(faces, before)]


def off_polygons(data: bytes) -> tuple:
    """An OFF file's vertices (n, 3) and faces as polygons of vertex indices (colours after them left out).

    Raises
    ------
    airmat.errors.InputError
        A header or a face line that does not parse.
    """
    lines = [ln.split() for ln in re.sub(rb"#[^\n]*", b"", data).splitlines()]
    lines = [ln for ln in lines if ln]
    first = lines[0]
    head = first[1:] if len(first) > 1 and first[0].endswith(b"OFF") else (lines[1] if first[0].endswith(b"OFF") else [])
    body = lines[1:] if len(first) > 1 else lines[2:]
    try:
        nv, nf = int(head[0]), int(head[1])
        vertices = np.array([ln[:3] for ln in body[:nv]], float).reshape(-1, 3)
        polygons = [np.array(ln[1:1 + int(ln[0])], np.int64) for ln in body[nv:nv + nf]]
    except (IndexError, ValueError) as exc:
        raise InputError(f"cannot read the OFF file's polygons: {exc}") from None
    return vertices, polygons


def ply_polygons(mesh) -> list | None:
    """A PLY's face list as trimesh keeps it (``metadata['_ply_raw']``), or None when it is not there."""
    raw = getattr(mesh, "metadata", {}).get("_ply_raw", {}).get("face")
    if raw is None:
        return None
    data = raw.get("data", {})
    names = data.dtype.names or () if isinstance(data, np.ndarray) else tuple(data)
    name = next((n for n in ("vertex_indices", "vertex_index") if n in names), None)
    if name is None:
        return None
    lists = data[name]
    if isinstance(lists, np.ndarray) and lists.dtype.names == ("f0", "f1"):    # binary: (count, fixed-size indices)
        count, idx = lists["f0"].astype(np.int64), np.atleast_2d(lists["f1"]).astype(np.int64)
        return [row[:c] for row, c in zip(idx, count)]
    return [np.asarray(p, np.int64) for p in lists]
