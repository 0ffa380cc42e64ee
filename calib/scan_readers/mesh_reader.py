"""PLY (points or mesh, any encoding), OBJ, STL, OFF, GLB and glTF through trimesh.

Binary PLY point clouds are read with numpy (:mod:`airmat.calib.scan_readers.ply_points`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
from pathlib import Path

import numpy as np

from airmat.errors import InputError
from airmat.calib.scan_readers.obj_indices import check_obj_indices
from airmat.calib.scan_readers.ply_header import ply_renamed_xyz, ply_vertex_float32, ply_xyz_fields
from airmat.calib.scan_readers.ply_points import read_binary_points
from airmat.calib.scan_readers.raw import RawCloud, library_message
from airmat.calib.scan_readers.stated_units import unit_from_comments

__all__ = ["read"]


def read(path: Path, *, scan_index=None, suffix: str | None = None) -> RawCloud:
    """Vertices (and faces) of a trimesh-readable file; a scene's parts are placed by their node poses.

    ``suffix`` is the format when the file's name says another one (a PLY named ``.xyz``). The unit is
    the one an exporter's comment states (OBJ ``# File units = inches``, PLY ``comment Units: cm``), if any.
    """
    suffix = (suffix or path.suffix).lower()
    cloud = _read(path, suffix)
    units = _comment_unit(path, suffix)
    return cloud if units is None else dataclasses.replace(cloud, units=units)


def _comment_unit(path: Path, suffix: str) -> str | None:
    """The unit named in an OBJ's leading ``#`` lines or a PLY header's ``comment``/``obj_info`` lines."""
    if suffix not in (".obj", ".ply"):
        return None
    with open(path, "rb") as fh:
        head = fh.read(1 << 14).decode("utf-8", errors="replace")
    if suffix == ".ply":
        head = head[:max(head.find("end_header"), 0)]
        lines = [ln for ln in head.splitlines() if ln.startswith(("comment", "obj_info"))]
    else:
        lines = [ln for ln in head.splitlines() if ln.lstrip().startswith("#")]
    return unit_from_comments(lines)


def _read(path: Path, suffix: str) -> RawCloud:
    float32 = suffix in (".stl", ".glb", ".gltf")  # these formats store 32-bit floats only
    stream = None
    if suffix == ".obj":
        check_obj_indices(path)
    if suffix == ".ply":
        cloud = read_binary_points(path)  # a scanner's binary point cloud: numpy, no trimesh
        if cloud is not None:
            return cloud
        float32 = ply_vertex_float32(path)
        fields = ply_xyz_fields(path)
        if fields != ("x", "y", "z"):     # X Y Z: trimesh reads lower-case names only
            stream = ply_renamed_xyz(path, fields)
    geometry = _load(path, suffix, stream)
    vertices, faces = _vertices_faces(geometry, path)
    return RawCloud(vertices=vertices, faces=faces, float32=float32)


@contextlib.contextmanager
def _quiet(name: str):
    """Silence a library's logger (trimesh logs tracebacks for, e.g., a missing texture)."""
    logger = logging.getLogger(name)
    level, logger.level = logger.level, logging.CRITICAL + 1
    try:
        yield
    finally:
        logger.setLevel(level)


def _load(path: Path, suffix: str, stream=None):
    import trimesh

    try:
        with _quiet("trimesh"), (contextlib.nullcontext(stream) if stream is not None else open(path, "rb")) as fh:
            return trimesh.load(fh, file_type=suffix[1:], process=False,
                                resolver=trimesh.resolvers.FilePathResolver(str(path)))
    except OSError as err:
        raise InputError(f"cannot read: {err.strerror or err}", path=path) from None
    except Exception as err:  # trimesh raises many types for malformed files
        raise InputError(f"cannot parse {suffix[1:].upper()} file (truncated or corrupt?): "
                         f"{library_message(err)}", path=path) from None


def _vertices_faces(geometry, path: Path):
    """(V, 3) float64 vertices and (F, 3) faces or None, from a trimesh object."""
    import trimesh

    if isinstance(geometry, trimesh.Scene):
        clouds = _scene_clouds(geometry)
        if clouds is not None:  # points only (a phone LiDAR GLB): no copies of the scene
            return clouds, None
        parts = [g for g in geometry.dump(concatenate=False) if hasattr(g, "vertices") and len(g.vertices)]
        if not parts:
            raise InputError("no points in the file", path=path)
        meshes = [g for g in parts if isinstance(g, trimesh.Trimesh)]
        if len(meshes) == len(parts):
            geometry = trimesh.util.concatenate(meshes)
        else:
            return np.concatenate([np.asarray(g.vertices, float) for g in parts]), None
    vertices = np.asarray(getattr(geometry, "vertices", np.empty((0, 3))), dtype=float)
    faces = getattr(geometry, "faces", None)
    if vertices.ndim != 2 or vertices.shape[1] != 3 or len(vertices) == 0:
        raise InputError("no points in the file", path=path)
    if faces is None or len(faces) == 0:
        return vertices, None
    faces = np.asarray(faces)
    if faces.ndim != 2 or faces.min() < 0 or faces.max() >= len(vertices):
        raise InputError(f"face vertex index out of range: {int(faces.min())}..{int(faces.max())} "
                         f"with {len(vertices)} vertices", path=path)
    return vertices, faces


def _scene_clouds(scene):
    """(V, 3) float64 points of a scene made of point clouds only, each placed by its node's
    transform (one pass per output column), or None when the scene holds a mesh or nothing.

    ``Scene.dump`` gives the same points but copies and transforms every part first, which
    for a million points costs several times the read.
    """
    import trimesh

    nodes = [scene.graph[node] for node in scene.graph.nodes_geometry]
    geoms = [scene.geometry.get(name) for _, name in nodes]
    if not geoms or not all(isinstance(g, trimesh.PointCloud) for g in geoms):
        return None
    parts = []
    for (matrix, _), g in zip(nodes, geoms):
        v = np.asarray(g.vertices, dtype=float)
        if len(v) == 0:
            continue
        if np.array_equal(matrix, np.eye(4)):
            parts.append(v)
            continue
        out = np.empty_like(v)
        for j in range(3):
            np.multiply(v[:, 0], matrix[j, 0], out=out[:, j])
            out[:, j] += matrix[j, 1] * v[:, 1]
            out[:, j] += matrix[j, 2] * v[:, 2]
            out[:, j] += matrix[j, 3]
        parts.append(out)
    return np.concatenate(parts) if len(parts) > 1 else parts[0] if parts else None
