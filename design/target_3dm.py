"""Targets read from Rhino's own .3dm files: its meshes, and the render meshes of its surfaces.

A .3dm file keeps NURBS surfaces, polysurfaces and extrusions exactly, and beside them the render
meshes Rhino made for them (unless saved with "Save Small"); rhino3dm (OpenNURBS) reads both but
cannot mesh a NURBS surface itself. So the target is every visible mesh object of the file together
with the render meshes of its visible surfaces, as one mesh; a surface saved without its render
mesh is refused, saying how to save it. The file's model units are its units.

Rhino's meshes hold quads. A quad can be split along either diagonal, and where it is warped the
two choices are different surfaces (:mod:`airmat.design.target` refuses the polygons of other
formats for that reason); a render mesh's quads are flat to within a small fraction of their size.
So each quad whose fourth corner lies within :data:`QUAD_WARP` of its diagonal from the plane of
the other three is split along its shorter diagonal, and a file with a more warped quad is refused.

rhino3dm hands vertices and faces out one by one (no array view): reading a mesh costs about 5 µs a
vertex in Python.
"""

from __future__ import annotations

import numpy as np

from airmat.errors import InputError

__all__ = ["read_3dm", "split_quads", "QUAD_WARP", "UNIT_NAMES"]

#: a quad is split when its fourth corner lies within this fraction of its longer diagonal from the plane
#: of the other three
QUAD_WARP = 0.01

#: rhino3dm's model unit systems that airmat names (:data:`airmat.design.target.UNITS`)
UNIT_NAMES = {"Millimeters": "mm", "Centimeters": "cm", "Meters": "m", "Inches": "in", "Feet": "ft"}


def split_quads(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Rhino's faces (m, 4) (a triangle repeats its third corner) as triangles (m', 3).

    Each quad is split along its shorter diagonal.

    Parameters
    ----------
    vertices : ndarray of shape (n, 3)
    faces : ndarray of shape (m, 4) of int

    Returns
    -------
    ndarray of shape (m', 3) of int
        The triangles, then the halves of the quads.

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
    f = np.asarray(faces, np.int64)
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
        raise InputError(f"{int(bad.sum())} of {len(q)} quads are warped (a corner up to {100 * warp.max():.1g} % of "
                         "the quad's diagonal off the plane of the other three), so either diagonal makes another "
                         "surface: mesh it finer (_Mesh) or triangulate it (_TriangulateMesh) and save again",
                         n_warped=int(bad.sum()), warp=float(warp.max()))
    short02 = d02 <= d13
    halves = np.where(short02[:, None, None],
                      np.stack([q[:, [0, 1, 2]], q[:, [0, 2, 3]]], axis=1),
                      np.stack([q[:, [0, 1, 3]], q[:, [1, 2, 3]]], axis=1))
    return np.concatenate([tri, halves.reshape(-1, 3)])


def _mesh_arrays(mesh) -> tuple:
    """A rhino3dm Mesh's vertices (n, 3) and faces (m, 4)."""
    v = np.array([(p.X, p.Y, p.Z) for p in mesh.Vertices.ToPoint3dArray()], float).reshape(-1, 3)
    f = np.array([mesh.Faces[i] for i in range(mesh.Faces.Count)], np.int64).reshape(-1, 4)
    return v, f


def read_3dm(path) -> tuple:
    """The target meshes of a .3dm file: (vertices (n, 3) in the file's units, triangles (m, 3), units).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    vertices : ndarray of shape (n, 3)
    faces : ndarray of shape (m, 3) of int
    units : str or None
        The file's model units as :data:`UNIT_NAMES` names them; None when it has none.

    Raises
    ------
    airmat.errors.InputError
        An unreadable file; no visible mesh, surface or extrusion in it; a surface saved without its
        render mesh; units airmat does not name; a warped quad (:func:`split_quads`).
    """
    import rhino3dm

    model = rhino3dm.File3dm.Read(str(path))
    if model is None:
        raise InputError("cannot read the target as 3DM (not a Rhino file, or from a newer Rhino than rhino3dm "
                         f"{rhino3dm.__version__} reads)")
    pieces, kinds, missing = [], set(), 0
    for obj in model.Objects:
        if not obj.Attributes.Visible:
            continue
        geom = obj.Geometry
        kind = type(geom).__name__
        if isinstance(geom, rhino3dm.Mesh):
            meshes = [geom]
        elif isinstance(geom, rhino3dm.Brep):
            meshes = [face.GetMesh(rhino3dm.MeshType.Any) for face in geom.Faces]
        elif isinstance(geom, rhino3dm.Extrusion):
            meshes = [geom.GetMesh(rhino3dm.MeshType.Any)]
        else:
            kinds.add(kind)
            continue
        missing += sum(m is None for m in meshes)
        pieces += [_mesh_arrays(m) for m in meshes if m is not None]
    if missing:
        raise InputError(f"{missing} surface(s) in the file have no render mesh (saved with 'Save Small', or never "
                         "shaded): save it again from a shaded view, or mesh it (_Mesh) and export OBJ",
                         n_missing=missing)
    if not pieces:
        others = f" (it holds {', '.join(sorted(kinds))})" if kinds else ""
        raise InputError(f"no visible mesh, surface or extrusion in the file{others}")
    offsets = np.cumsum([0] + [len(v) for v, _ in pieces[:-1]])
    vertices = np.concatenate([v for v, _ in pieces])
    faces = np.concatenate([f + o for (_, f), o in zip(pieces, offsets)])
    system = model.Settings.ModelUnitSystem.name
    if system in ("None", "Unset"):
        units = None
    elif system in UNIT_NAMES:
        units = UNIT_NAMES[system]
    else:
        raise InputError(f"the file's model units are {system}: save it in millimetres, centimetres, metres, inches "
                         "or feet", units=system)
    return vertices, split_quads(vertices, faces), units
