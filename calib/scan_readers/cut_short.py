"""Files cut short: a mesh or scan whose copy or download stopped is refused before it is read.

trimesh, open3d and the column readers read many truncated files without
complaint and return part of the mesh or cloud (a target designed on part of
its surface; an ascii PCD that open3d pads with zeros up to its declared
count), or fail with a message that does not say what is wrong ("PLY is
unexpected length!", "buffer size must be a multiple of element size").
These checks run before them, on the file's bytes, one per format:

- PLY: the counts of its header against the body
  (:func:`airmat.calib.scan_readers.ply_header.check_ply_complete`);
- OFF: the vertex and face counts of its header against its rows, and the
  values of its last row (ascii PCD: the reader counts its rows against POINTS);
- binary STL: the triangle count of its header against the file size; ASCII
  STL: its closing ``endsolid``; LAS (uncompressed): the point count and
  record size of its header against the file size (laspy reads the header);
- OBJ (no counts): its last record; PTS/XYZ/TXT columns: the line break
  below, or a last row as long as the one before it.

A text body (ascii PLY and PCD, OFF, OBJ, columns) must end with a line break:
a file cut inside its last number looks complete otherwise ("f 12 345 6" of
"f 12 345 6789"). Every exporter we know ends its last line; a hand-edited
file that does not is refused with a message saying to add one. A file
without counts (OBJ, columns) cut exactly at the end of a line cannot be told
from a whole one. Binary PCD, compressed formats (LAZ, E57, GLB) and binary
OFF are left to their readers, which check their own sizes.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from airmat.errors import InputError
from airmat.calib.scan_readers.ply_header import check_ply_complete

__all__ = ["check_complete", "complete_binary_stl"]

#: how much of a file's end is read to find its last record (bytes)
TAIL = 4096


def check_complete(path, *, suffix: str | None = None) -> None:
    """Raise :class:`airmat.errors.InputError` (naming ``path``) when a mesh or scan file is cut short.

    Parameters
    ----------
    path : str or Path
        A mesh or scan file; the check is chosen by its suffix (PLY, OFF, STL, OBJ, ascii PCD, LAS,
        PTS/XYZ/TXT; other suffixes are not checked).
    suffix : str, optional
        The format, when the file's own suffix names another one.

    Raises
    ------
    airmat.errors.InputError
        Saying what the header declares and what the file holds, or which record is incomplete.
    """
    path = Path(path)
    if path.is_file() and path.stat().st_size == 0:
        return  # an empty file: the reader says it holds no mesh
    check = {".ply": _check_ply, ".off": _check_off, ".stl": _check_stl, ".obj": _check_obj,
             ".pcd": _check_pcd, ".las": _check_las, ".pts": _check_columns, ".xyz": _check_columns,
             ".txt": _check_columns}
    fn = check.get((suffix or path.suffix).lower())
    if fn is None:
        return
    try:
        fn(path)
    except OSError as err:
        raise InputError(f"cannot read: {err.strerror or err}", path=path) from None


def _tail(path: Path) -> bytes:
    with open(path, "rb") as fh:
        fh.seek(0, 2)
        fh.seek(max(fh.tell() - TAIL, 0))
        return fh.read()


def _ends_inside_a_line(path: Path, kind: str) -> None:
    tail = _tail(path).rstrip(b" \t")
    if tail and not tail.endswith((b"\n", b"\r")):
        raise InputError(f"truncated {kind}: the file ends inside a line (cut short? a complete file "
                         "ends with a line break; if this one is complete, add one)", path=path)


def _check_ply(path: Path) -> None:
    if check_ply_complete(path):   # ascii
        _ends_inside_a_line(path, "PLY")


def _check_off(path: Path) -> None:
    text = re.sub(rb"#[^\n]*", b"", path.read_bytes())
    if b"BINARY" in text[:64].upper():
        return  # binary OFF: left to the reader
    head = text[:256].split(maxsplit=4)
    if not head or not head[0].upper().endswith(b"OFF"):
        raise InputError("not an OFF file (its first word is not 'OFF')", path=path)
    if len(head) < 3 or not (head[1].isdigit() and head[2].isdigit()):
        raise InputError("malformed OFF header: no 'vertices faces edges' counts after 'OFF'", path=path)
    nv, nf = int(head[1]), int(head[2])
    # rows that hold a value, the header's one or two included (counted in C, not per row in Python)
    rows = len(re.findall(rb"(?m)^[ \t]*\S", text))
    header_rows = 1 if re.match(rb"\s*\S+[ \t]+\d", text) else 2   # "OFF nv nf ne" on one line, or two
    if rows - header_rows < nv + nf:
        raise InputError(f"truncated OFF: the header declares {nv} vertices and {nf} faces "
                         f"({nv + nf} rows), the file has {max(rows - header_rows, 0)}", path=path)
    if rows - header_rows == nv + nf and nv + nf:
        last = text.rstrip().rsplit(b"\n", 1)[-1].split()
        need = 3 if nf == 0 else 1 + int(last[0]) if last[0].isdigit() else None
        if need is None or len(last) < need:
            kind = "vertex" if nf == 0 else "face"
            raise InputError(f"truncated OFF: the last {kind} row has {len(last)} values, expected "
                             f"{need if need is not None else 'a corner count first'}", path=path)
    _ends_inside_a_line(path, "OFF")


def complete_binary_stl(path: Path) -> bool:
    """Whether ``path`` is a binary STL whose size is exactly what its triangle count takes."""
    with open(path, "rb") as fh:
        head = fh.read(84)
    return len(head) == 84 and path.stat().st_size == 84 + 50 * int(np.frombuffer(head[80:84], "<u4")[0])


def _check_stl(path: Path) -> None:
    if complete_binary_stl(path):
        return
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(512)
    declared = int(np.frombuffer(head[80:84], "<u4")[0]) if len(head) >= 84 else None
    if head.lstrip().startswith(b"solid") and b"facet" in head:
        last = _tail(path).rstrip().rsplit(b"\n", 1)[-1].strip()
        if not last.startswith(b"endsolid"):
            raise InputError("truncated STL: the ASCII file does not end with 'endsolid'", path=path)
        return
    if declared is None:
        raise InputError(f"truncated STL: {size} bytes, shorter than a binary STL's 84-byte header",
                         path=path)
    if size < 84 + 50 * declared:
        raise InputError(f"truncated STL: the header declares {declared} triangles "
                         f"({84 + 50 * declared} bytes), the file has {size}", path=path)


#: least values of an OBJ record after its keyword
_OBJ_VALUES = {b"v": 3, b"vn": 3, b"f": 3, b"vt": 1}


def _check_obj(path: Path) -> None:
    lines = _tail(path).splitlines()
    last = next((ln.split() for ln in reversed(lines) if ln.strip()), None)
    if last and last[0] in _OBJ_VALUES and len(last) - 1 < _OBJ_VALUES[last[0]]:
        raise InputError(f"truncated OBJ: the last {last[0].decode()!r} record has {len(last) - 1} values, "
                         f"expected {_OBJ_VALUES[last[0]]}", path=path)
    _ends_inside_a_line(path, "OBJ")


def _check_columns(path: Path) -> None:
    """A column file may end without a line break when its last row is as complete as the one before:
    as many fields, its last one with as many digits after the point (exporters print a fixed number of
    decimals; a number cut short has fewer)."""
    tail = _tail(path).rstrip(b" \t")
    if not tail or tail.endswith((b"\n", b"\r")):
        return
    rows = [ln.replace(b",", b" ").replace(b";", b" ").split() for ln in tail.splitlines()[-3:] if ln.strip()]
    if len(rows) >= 2 and len(rows[-1]) == len(rows[-2]) and _decimals(rows[-1][-1]) == _decimals(rows[-2][-1]):
        return
    _ends_inside_a_line(path, path.suffix[1:].upper())


def _decimals(token: bytes) -> int:
    """Digits after the decimal point of a printed number (-1 without one)."""
    mantissa = token.lower().split(b"e")[0]
    return len(mantissa) - mantissa.index(b".") - 1 if b"." in mantissa else -1


def _check_pcd(path: Path) -> None:
    """An ascii body must end with a line break; its rows against POINTS are counted by the reader
    (:mod:`airmat.calib.scan_readers.pcd_reader`: polars' rows, or the line breaks before open3d reads it)."""
    with open(path, "rb") as fh:
        head = fh.read(1 << 14)
    if re.search(rb"(?m)^DATA[ \t]+ascii", head):
        _ends_inside_a_line(path, "PCD")


def _check_las(path: Path) -> None:
    import laspy

    try:
        with laspy.open(str(path)) as reader:
            header = reader.header
            if header.are_points_compressed:
                return   # a LAZ body under a .las name: lazrs checks its chunks
            need = header.offset_to_point_data + header.point_count * header.point_format.size
    except OSError:
        raise
    except Exception:   # a header laspy cannot read: the reader reports it
        return
    size = path.stat().st_size
    if size < need:
        raise InputError(f"truncated LAS: the header declares {header.point_count} points of "
                         f"{header.point_format.size} bytes after {header.offset_to_point_data} bytes of header "
                         f"({need} bytes), the file has {size}", path=path)
