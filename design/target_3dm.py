"""Targets read from Rhino's own .3dm files: its meshes, and the render meshes of its surfaces.

A .3dm file keeps NURBS surfaces, polysurfaces and extrusions exactly, and beside them the render
meshes Rhino made for them (unless saved with "Save Small"); rhino3dm (OpenNURBS) reads both but
cannot mesh a NURBS surface itself. So the target is every visible mesh object of the file together
with the render meshes of its visible surfaces, as one mesh; a surface saved without its render
mesh is refused, saying how to save it. The file's model units are its units.

Rhino's meshes hold quads, split as every format's are (:func:`airmat.design.target_polygons.split_quads`).

rhino3dm hands vertices and faces out one by one (no array view): reading a mesh costs about 5 µs a
vertex in Python.
"""

from __future__ import annotations

import numpy as np

from airmat.design.target_polygons import split_quads
from airmat.errors import InputError

__all__ = ["read_3dm", "UNIT_NAMES"]

#: rhino3dm's model unit systems that airmat names (:data:`airmat.design.target.UNITS`)
UNIT_NAMES = {"Millimeters": "mm", "Centimeters": "cm", "Meters": "m", "Inches": "in", "Feet": "ft"}


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
        No rhino3dm here; an unreadable file; no visible mesh, surface or extrusion in it; a surface saved without its
        render mesh; units airmat does not name; a warped quad (:func:`split_quads`).
    """
    try:
        import rhino3dm
    except ImportError:
        raise InputError("reading a .3dm file needs rhino3dm, which has no wheel for this Python on this machine: "
                         "export the target as OBJ from Rhino (or use Python 3.11 or later)") from None

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
