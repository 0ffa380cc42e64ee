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
import logging
import os
from pathlib import Path

from airmat.calib.scan_readers.raw import RawCloud, check_plausible

__all__ = ["RawCloud", "READERS", "SUPPORTED_SUFFIXES", "read_cloud", "sniff_format"]

log = logging.getLogger(__name__)

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

    suffix = path.suffix.lower()
    sniffed = sniff_format(path)
    if sniffed is not None and READERS[sniffed] != name:
        log.warning("%s: the file is a %s, not what its name says (%s): read as %s", path, sniffed[1:].upper(),
                    suffix, sniffed[1:].upper())
        suffix, name = sniffed, READERS[sniffed]
    check_complete(path, suffix=suffix)   # a file cut short would give part of the scan, or a library's message
    module = importlib.import_module(f"airmat.calib.scan_readers.{name}")
    # mesh_reader: the one reader whose library is told the format
    cloud = module.read(path, scan_index=scan_index, **({"suffix": suffix} if name == "mesh_reader" else {}))
    return check_plausible(cloud, path)


#: leading bytes of the formats that have them -> the suffix they are read as
_MAGIC = ((b"ply\n", ".ply"), (b"ply\r\n", ".ply"), (b"LASF", ".las"), (b"ASTM-E57", ".e57"), (b"glTF", ".glb"),
          (b"# .PCD", ".pcd"))


def sniff_format(path) -> str | None:
    """The suffix of the format a file's leading bytes identify (PLY, LAS/LAZ, E57, GLB, PCD), or None.

    A file is read by what it holds, not by what its name says: a binary PLY saved as ``.xyz`` would
    otherwise be refused as a truncated column file.
    """
    try:
        with open(path, "rb") as fh:
            head = fh.read(16)
    except OSError:
        return None
    return next((suffix for magic, suffix in _MAGIC if head.startswith(magic)), None)
