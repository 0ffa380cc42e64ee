"""Files of the near-developable surface Ŝ, with each vertex's position on Ω, and of the target S.

``approx_surface.ply``: binary PLY, vertex ``x, y, z`` (mm) plus the Ω
coordinates ``u_mm, v_mm`` of every vertex; ``approx_surface.obj``: the
same mesh with ``vt`` = (u / W, v / H). ``target.ply``: the user's target S,
binary PLY, vertex ``x, y, z`` (mm), in the frame Ŝ is in (Ŝ was relaxed onto
S where S is: one frame for both). Coordinates are float32 in the files; the
library side is in metres.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from airmat.atomic import atomic_write_bytes
from airmat.errors import InputError
from airmat.units import M_TO_MM, MM
from airmat.calib.scan_readers.cut_short import check_complete

__all__ = ["write_approx_surface", "read_approx_surface", "write_target_surface", "read_target_surface"]


def write_approx_surface(folder, xyz, uv, faces, *, width, height, stem="approx_surface"):
    """Write ``<stem>.ply`` and ``<stem>.obj`` into ``folder``.

    Parameters
    ----------
    xyz : ndarray of shape (n, 3)
        Vertex positions of Ŝ (m).
    uv : ndarray of shape (n, 2)
        Their positions on Ω (m).
    faces : ndarray of shape (m, 3)
        Triangles (shared by Ŝ and Ω).
    width, height : float
        W and H of Ω (m), to normalise the OBJ texture coordinates.
    """
    folder = Path(folder)
    mesh = trimesh.Trimesh(np.asarray(xyz) * M_TO_MM, np.asarray(faces), process=False)
    mesh.vertex_attributes["u_mm"] = np.asarray(uv[:, 0], float) * M_TO_MM
    mesh.vertex_attributes["v_mm"] = np.asarray(uv[:, 1], float) * M_TO_MM
    atomic_write_bytes(folder / f"{stem}.ply",
                       trimesh.exchange.ply.export_ply(mesh, encoding="binary", include_attributes=True))
    tex = np.column_stack([uv[:, 0] / width, uv[:, 1] / height])
    mesh_obj = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False,
                               visual=trimesh.visual.TextureVisuals(uv=tex))
    text = trimesh.exchange.obj.export_obj(mesh_obj, include_texture=True, include_normals=False,
                                           write_texture=False)
    # no material file is written: drop trimesh's dangling mtllib/usemtl references
    lines = [ln for ln in text.splitlines() if not ln.startswith(("mtllib", "usemtl"))]
    atomic_write_bytes(folder / f"{stem}.obj", ("\n".join(lines) + "\n").encode())


def read_approx_surface(path):
    """Read an ``approx_surface.ply`` written by :func:`write_approx_surface`.

    Returns
    -------
    xyz : ndarray of shape (n, 3)
        Vertex positions (m).
    uv : ndarray of shape (n, 2)
        Positions on Ω (m).
    faces : ndarray of shape (m, 3)

    Raises
    ------
    airmat.errors.InputError
        When the file is missing, unreadable, cut short (:mod:`airmat.calib.scan_readers.cut_short`) or
        lacks the ``u_mm``/``v_mm`` properties.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("file not found (expected the approx_surface.ply of a design folder)", path=path)
    check_complete(path)   # a file cut short: say so, not "not an airmat approx_surface.ply"
    try:
        mesh = trimesh.load(path, file_type="ply", process=False, force="mesh")
        raw = mesh.metadata["_ply_raw"]["vertex"]["data"]
        uv = np.column_stack([raw["u_mm"], raw["v_mm"]]).astype(float) * MM
    except (KeyError, ValueError, IndexError, TypeError) as exc:
        raise InputError(f"not an airmat approx_surface.ply (needs vertex properties u_mm, v_mm): {exc}",
                         path=path) from exc
    return np.asarray(mesh.vertices, float) * MM, uv, np.asarray(mesh.faces)


def write_target_surface(path, target) -> None:
    """Write the target S as ``target.ply``: binary PLY, vertex ``x, y, z`` (float32 mm), triangles.

    Parameters
    ----------
    path : str or Path
    target : airmat.design.target.Target
        S (m), in the frame Ŝ is in (that of the target the design was relaxed onto).
    """
    mesh = trimesh.Trimesh(np.asarray(target.vertices) * M_TO_MM, np.asarray(target.faces), process=False)
    atomic_write_bytes(Path(path), trimesh.exchange.ply.export_ply(mesh, encoding="binary", include_attributes=False))


def read_target_surface(path, *, name: str = "target"):
    """Read a ``target.ply`` written by :func:`write_target_surface`.

    Parameters
    ----------
    path : str or Path
    name : str, default "target"
        The target's name (a design folder's: the design's).

    Returns
    -------
    airmat.design.target.Target
        S in metres (float32 mm in the file), in Ŝ's frame; units ``"mm"``.

    Raises
    ------
    airmat.errors.InputError
        When the file is missing, unreadable, cut short or not a valid target mesh (naming ``path``).
    """
    from airmat.design.target import Target

    path = Path(path)
    if not path.is_file():
        raise InputError("file not found (expected the target.ply of a design folder)", path=path)
    check_complete(path)
    try:
        mesh = trimesh.load(path, file_type="ply", process=False, force="mesh")
        vertices, faces = np.asarray(mesh.vertices, float), np.asarray(mesh.faces)
    except (KeyError, ValueError, IndexError, TypeError, AttributeError) as exc:
        raise InputError(f"not readable as the design's target.ply: {exc}", path=path) from exc
    try:
        return Target(vertices * MM, faces, name=name, units="mm")
    except InputError as err:
        raise err.with_path(path)
