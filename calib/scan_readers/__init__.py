"""One reader per scan format, and the registry that picks one by file suffix.

Each reader module holds one function ``read(path, *, scan_index) -> RawCloud``
built on a well-kept library; :func:`read_cloud` imports only the reader the
file needs (an ``airmat fit`` of a PLY loads no pye57 or laspy).

========================  ====================  ==================================================================
suffix                    reader module         library
========================  ====================  ==================================================================
.ply .obj .stl .off       ``mesh_reader``       trimesh; binary PLY point clouds: numpy
.glb .gltf                ``mesh_reader``       trimesh (scenes with their node poses)
.e57                      ``e57_reader``        pye57's libE57 (one scan, or all with their poses)
.las .laz                 ``las_reader``        laspy with the lazrs LAZ backend (parallel, x/y/z layers)
.pcd                      ``pcd_reader``        polars (ascii); numpy (binary); python-lzf or open3d (compressed)
.pts .xyz .txt            ``text_reader``       polars, numpy fallback (columns, header/count line)
========================  ====================  ==================================================================
"""

from __future__ import annotations

import importlib
import os
from pathlib import Path

from airmat.calib.scan_readers.raw import RawCloud

__all__ = ["RawCloud", "READERS", "SUPPORTED_SUFFIXES", "read_cloud"]

#: file suffix -> the module under airmat.calib.scan_readers that reads it
READERS = {
    ".ply": "mesh_reader", ".obj": "mesh_reader", ".stl": "mesh_reader", ".off": "mesh_reader",
    ".glb": "mesh_reader", ".gltf": "mesh_reader",
    ".e57": "e57_reader",
    ".las": "las_reader", ".laz": "las_reader",
    ".pcd": "pcd_reader",
    ".pts": "text_reader", ".xyz": "text_reader", ".txt": "text_reader",
}
#: every suffix read_cloud understands
SUPPORTED_SUFFIXES = tuple(READERS)


def read_cloud(path: str | os.PathLike, *, scan_index: int | None = None) -> RawCloud:
    """Read a scan file's coordinates in the file's own unit, float64, unfiltered.

    Parameters
    ----------
    path : path
        A file with one of :data:`SUPPORTED_SUFFIXES` (case-insensitive).
    scan_index : int, optional
        Which scan of a multi-scan file (E57) to read; all of them, merged
        with their poses, when omitted. Other formats accept only None or 0.

    Returns
    -------
    RawCloud

    Raises
    ------
    airmat.errors.InputError
        With ``path`` set, for an unsupported suffix, a file cut short
        (:mod:`airmat.calib.scan_readers.cut_short`) or a file the library cannot parse.
    """
    from airmat.errors import InputError

    path = Path(path)
    name = READERS.get(path.suffix.lower())
    if name is None:
        raise InputError(f"unsupported scan format {path.suffix or '(no suffix)'!r}; "
                         f"use one of {', '.join(SUPPORTED_SUFFIXES)}", path=path)
    if scan_index is not None and name != "e57_reader" and scan_index != 0:
        raise InputError(f"--scan-index {scan_index}: a {path.suffix} file holds one scan", path=path)
    from airmat.calib.scan_readers.cut_short import check_complete

    check_complete(path)   # a file cut short would give part of the scan, or a library's message
    module = importlib.import_module(f"airmat.calib.scan_readers.{name}")
    return module.read(path, scan_index=scan_index)
