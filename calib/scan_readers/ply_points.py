"""Binary PLY point clouds straight into numpy, without a mesh library.

A scanner's binary PLY is one ``vertex`` element of scalar properties
(``x y z`` and often colours, normals, intensity): its body is a packed
array that ``np.fromfile`` reads in one call with a structured dtype built
from the header. Files this does not cover (ascii, faces, list properties)
return None and go to trimesh (:mod:`airmat.calib.scan_readers.mesh_reader`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from airmat.errors import InputError
from airmat.calib.scan_readers.raw import RawCloud

__all__ = ["read_binary_points", "PLY_TYPES", "xyz_names"]

#: PLY scalar type -> numpy type character
PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
          "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
          "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}


def xyz_names(names) -> tuple[str, str, str] | None:
    """The vertex properties holding x, y, z: ``x y z``, else ``X Y Z`` (any case); None when absent or ambiguous.

    Examples
    --------
    >>> xyz_names(["x", "y", "z", "red"]), xyz_names(["X", "Y", "Z"]), xyz_names(["x", "X", "y", "z"])
    (('x', 'y', 'z'), ('X', 'Y', 'Z'), ('x', 'y', 'z'))
    >>> xyz_names(["px", "py", "pz"]) is None
    True
    """
    names = list(names)
    if len(set(names)) != len(names):
        return None
    if {"x", "y", "z"} <= set(names):
        return ("x", "y", "z")
    lower = {}
    for name in names:
        lower.setdefault(name.lower(), []).append(name)
    if all(len(lower.get(c, [])) == 1 for c in "xyz"):
        return tuple(lower[c][0] for c in "xyz")
    return None


def read_binary_points(path: Path) -> RawCloud | None:
    """The vertices of a binary PLY point cloud, or None for any other PLY.

    Parameters
    ----------
    path : Path
        A PLY file (its header already checked by
        :func:`airmat.calib.scan_readers.ply_header.check_ply_complete`).

    Returns
    -------
    RawCloud or None
        Float64 coordinates (exact copies of float32 ones); None when the
        file is ascii, has faces or other non-empty elements, or list
        properties.

    Raises
    ------
    airmat.errors.InputError
        When the body holds fewer bytes than the header declares.
    """
    with open(path, "rb") as fh:
        head = fh.read(1 << 16)
    end = head.find(b"end_header")
    if end < 0 or b"\n" not in head[end:]:
        return None
    body = head.index(b"\n", end) + 1
    layout = _vertex_layout(head[:body].decode("ascii", errors="replace").split("\n"))
    if layout is None:
        return None
    dtype, count, xyz_fields = layout
    if path.stat().st_size - body < dtype.itemsize * count:
        raise InputError(f"truncated PLY: element 'vertex' declares {count} rows of {dtype.itemsize} bytes, "
                         f"the body has {path.stat().st_size - body} bytes", path=path)
    data = np.fromfile(path, dtype=dtype, count=count, offset=body)
    xyz = np.empty((count, 3))
    with np.errstate(invalid="ignore"):   # a damaged body's signalling NaNs: judged by read_cloud, not warned
        for j, name in enumerate(xyz_fields):
            xyz[:, j] = data[name]
    return RawCloud(vertices=xyz, float32=dtype[xyz_fields[0]].itemsize == 4)


def _vertex_layout(header: list[str]):
    """(structured dtype, count, x/y/z field names) of a binary file's only element ``vertex``, or None."""
    order = None
    elements = []
    for line in header:
        words = line.split()
        if words[:1] == ["format"] and len(words) >= 2:
            order = {"binary_little_endian": "<", "binary_big_endian": ">"}.get(words[1])
        elif words[:1] == ["element"] and len(words) == 3 and words[2].isdigit():
            elements.append((words[1], int(words[2]), []))
        elif words[:1] == ["property"] and elements:
            elements[-1][2].append(words[1:])
    if order is None or not elements or elements[0][0] != "vertex":
        return None
    if any(count for _, count, _ in elements[1:]):
        return None  # faces or other data: a mesh
    _, count, props = elements[0]
    if any(len(p) != 2 or p[0] not in PLY_TYPES for p in props):
        return None  # list properties
    names = [p[1] for p in props]
    fields = xyz_names(names)
    if fields is None:
        return None
    return np.dtype([(name, order + PLY_TYPES[t]) for t, name in props]), count, fields
