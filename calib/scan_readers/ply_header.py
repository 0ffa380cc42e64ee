"""PLY header checks: a complete body, in the byte order the header says, and whether the vertex coordinates are
32-bit floats."""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np

from airmat.errors import InputError
from airmat.calib.scan_readers.ply_points import PLY_TYPES, xyz_names

__all__ = ["check_ply_complete", "ply_elements", "ply_vertex_float32", "ply_vertex_names", "ply_xyz_fields",
           "ply_renamed_xyz"]


def _vertex_properties(path: Path) -> list[list[str]]:
    """The words after ``property`` of each of a PLY file's ``vertex`` properties (type words, then the name)."""
    with open(path, "rb") as fh:
        head = fh.read(1 << 16)
    lines = head[:max(head.find(b"end_header"), 0)].decode("ascii", errors="replace").split("\n")
    return next((props for name, _, props in ply_elements(lines, path) if name == "vertex"), [])


def ply_vertex_names(path: Path) -> list[str]:
    """The names of a PLY file's ``vertex`` properties, in order (list properties included)."""
    return [p[-1] for p in _vertex_properties(path)]


def ply_xyz_fields(path: Path) -> tuple[str, str, str]:
    """The names of a PLY file's x, y, z vertex properties (``x y z`` or ``X Y Z``); InputError when it has none."""
    names = ply_vertex_names(path)
    fields = xyz_names(names)
    if fields is None:
        raise InputError(f"the PLY's vertex element has no x, y, z properties (it has: "
                         f"{', '.join(names) or 'none'})", path=path)
    return fields


def ply_renamed_xyz(path: Path, fields) -> io.BytesIO:
    """The PLY file in memory with its coordinate properties ``fields`` renamed ``x y z`` (trimesh reads only those)."""
    data = path.read_bytes()
    end = data.find(b"end_header")
    head = data[:end]
    for old, new in zip(fields, "xyz"):
        head = re.sub(rb"(?m)^(property\s+\S+\s+)" + re.escape(old.encode()) + rb"(\s*)$",
                      rb"\g<1>" + new.encode() + rb"\g<2>", head)
    return io.BytesIO(head + data[end:])


def ply_vertex_float32(path: Path) -> bool:
    """Whether a PLY file's vertex ``x`` (or ``X``) property is a 32-bit float."""
    props = _vertex_properties(path)
    fields = xyz_names([p[-1] for p in props])
    return fields is not None and next(p[0] for p in props if p[-1] == fields[0]) in ("float", "float32")


def check_ply_complete(path: Path) -> bool:
    """Raise InputError when a PLY header is missing or the body is cut short; whether it is ascii.

    trimesh silently accepts an ascii body cut inside its last line or a face
    element cut short, and names a binary truncation only as "unexpected
    length"; this checks the header's element counts against the body: for
    ascii the rows of each element and the values of its last row (a list
    property holds as many values as its count says), for binary the least
    body size the header allows (every list empty: exact when there is no
    list property).
    """
    try:
        fh = open(path, "rb")
    except OSError as err:
        raise InputError(f"cannot read: {err.strerror or err}", path=path) from None
    with fh:
        head = fh.read(1 << 16)
        end = head.find(b"end_header")
        if not head.startswith(b"ply") or end < 0:
            raise InputError("not a PLY file (no 'ply ... end_header' header)", path=path)
        body_start = head.index(b"\n", end) + 1 if b"\n" in head[end:] else len(head)
        header = head[:body_start].decode("ascii", errors="replace").split("\n")
        elements = ply_elements(header, path)
        if not any(line.split()[:2] == ["format", "ascii"] for line in header):
            little = any(line.split()[:2] == ["format", "binary_little_endian"] for line in header)
            _check_binary_size(elements, fh, body_start, little, path)
            _check_byte_order(elements, fh, body_start, little, path)
            return False
        fh.seek(body_start)
        body = fh.read()
    starts, ends = _rows(body)
    start = 0
    for name, count, props in elements:
        if count == 0:
            continue
        last = start + count - 1
        if last >= len(starts):
            raise InputError(f"truncated PLY: element {name!r} declares {count} rows, "
                             f"the file has {max(len(starts) - start, 0)}", path=path)
        tokens = body[starts[last]:ends[last]].decode("ascii", errors="replace").split()
        expected = _row_values(props, tokens)
        if expected != len(tokens):
            raise InputError(f"truncated PLY: last {name!r} row has {len(tokens)} values, expected "
                             f"{expected if expected is not None else 'a list count first'}", path=path)
        start += count
    return True


def _rows(body: bytes):
    """Start and end offsets (k,) of the lines of ``body`` that hold a value (blank lines skipped),
    found with numpy, not line by line."""
    text = np.frombuffer(body, np.uint8)
    ends = np.flatnonzero(text == 10)
    if len(text) and text[-1] != 10:
        ends = np.r_[ends, len(text)]
    starts = np.r_[0, ends[:-1] + 1][:len(ends)]
    filled = ends > starts
    if filled.any():   # a line holds a value when it has a byte above 32 (not blank, tab or CR)
        filled[filled] = np.logical_or.reduceat(text > 32, starts[filled])
    return starts[filled], ends[filled]


def _row_values(props, tokens) -> int | None:
    """How many values an ascii row of an element with properties ``props`` must hold, its list
    properties' counts read from the row's ``tokens``; None when a list's count is missing or not
    an integer."""
    i = 0
    for prop in props:
        if prop[0] == "list":
            if i >= len(tokens) or not tokens[i].isdigit():
                return None
            i += 1 + int(tokens[i])
        else:
            i += 1
    return i


#: bytes of a PLY scalar type
_SIZES = {name: np.dtype(code).itemsize for name, code in PLY_TYPES.items()}


def _check_binary_size(elements, fh, body_start: int, little: bool, path) -> None:
    """Raise InputError when a binary body is shorter than its header allows.

    Scalar properties have fixed sizes; a list counts as empty (a lower bound), except
    in an element whose only property is a list (a face element) after fixed-size
    elements only: its rows are taken as long as its first (exact for triangles), and
    a body too short for that is refused only when every row it holds is that long
    (a mesh of triangles and quads is left to the reader).
    """
    fh.seek(0, 2)
    body = fh.tell() - body_start
    least, fixed, uniform = 0, True, None
    for _, count, words in elements:
        # "list <count type> <item type> <name>": its count's size; a scalar: its size
        sizes = [_SIZES.get(w[1] if w[0] == "list" and len(w) > 3 else w[0]) for w in words if len(w) > 1]
        if None in sizes or len(sizes) != len(words):
            return  # a type this check does not know: leave the file to the reader
        row = sum(sizes)
        lists = [w[0] == "list" for w in words]
        if lists == [True] and fixed and count and uniform is None and words[0][2] in _SIZES:
            fh.seek(body_start + least)
            first = fh.read(sizes[0])
            if len(first) == sizes[0]:
                row += int.from_bytes(first, "little" if little else "big") * _SIZES[words[0][2]]
                uniform = (least, count, row, first)
        elif any(lists):
            fixed = False
        least += count * row
    if body >= least:
        return
    if uniform is not None:
        start, count, row, first = uniform
        fh.seek(body_start + start)
        data = np.frombuffer(fh.read(min(count * row, body - start)), np.uint8)
        at = np.arange(0, len(data) - len(first) + 1, row)   # where each row's count would start
        counts = data[at[:, None] + np.arange(len(first))]
        if not (counts == np.frombuffer(first, np.uint8)).all():
            return  # rows of other lengths: the reader decides
    listed = ", ".join(f"{count} {name}" for name, count, _ in elements if count)
    need = f"{least} bytes with every face as long as the first" if uniform is not None else f"at least {least} bytes"
    raise InputError(f"truncated PLY: the header declares {listed}, which take {need}; the body has {body}",
                     path=path)


#: vertices sampled from the start of a binary body to check its byte order
BYTE_ORDER_SAMPLE = 1000


def _coordinate_share(xyz: np.ndarray) -> float:
    """Share of the values that look like coordinates: finite, and 0 or between 1e-9 and 1e7 in size."""
    size = np.abs(xyz)
    return float((np.isfinite(xyz) & ((size == 0) | ((size > 1e-9) & (size < 1e7)))).mean())


def _check_byte_order(elements, fh, body_start: int, little: bool, path) -> None:
    """Raise InputError when a binary body's vertices read as coordinates only in the other byte order.

    A file written little-endian under a ``binary_big_endian`` header (or the
    reverse) reads as values like 1e35 or 1e-41: trimesh then reported "face
    indices must be integers in [0, 1715]" for a target, and the scan reader
    an extent of 2.7e35 m. Only a body whose first element is ``vertex`` with
    scalar ``x``, ``y``, ``z`` is checked, on its first
    :data:`BYTE_ORDER_SAMPLE` rows; the declared order is refused when fewer
    than half of their coordinates look like coordinates and more than 95 %
    do in the other order (a scan padded with NaN rows fails both, and is left
    to the reader).
    """
    if not elements or elements[0][0] != "vertex":
        return
    _, count, props = elements[0]
    if any(len(p) != 2 or p[0] not in PLY_TYPES for p in props):
        return
    fields = xyz_names([p[1] for p in props])
    if fields is None:
        return
    dtypes = {order: np.dtype([(name, order + PLY_TYPES[t]) for t, name in props]) for order in "<>"}
    size = dtypes["<"].itemsize
    fh.seek(body_start)
    raw = fh.read(BYTE_ORDER_SAMPLE * size)
    n = min(len(raw) // size, count)
    if n == 0:
        return
    declared, other = ("<", ">") if little else (">", "<")
    rows = {o: np.frombuffer(raw, dtypes[o], count=n) for o in "<>"}
    with np.errstate(invalid="ignore", over="ignore"):   # the wrong order may read as signalling NaNs
        xyz = {o: np.column_stack([rows[o][c].astype(float) for c in fields]) for o in "<>"}
    if _coordinate_share(xyz[declared]) < 0.5 and _coordinate_share(xyz[other]) > 0.95:
        names = {"<": "binary_little_endian", ">": "binary_big_endian"}

        def first_vertex(o):
            return "(" + ", ".join(f"{v:.4g}" for v in xyz[o][0]) + ")"
        raise InputError(f"the vertices do not read as coordinates in the header's byte order "
                         f"({names[declared]}: the first is {first_vertex(declared)}) but do in the other "
                         f"({first_vertex(other)}): the file was written {names[other]}; fix the header's "
                         f"'format' line or export it again", path=path)


def ply_elements(header, path):
    """[(name, count, [property words])] from PLY header lines: each property's words after
    ``property``, its type words then its name (``["float", "x"]``, ``["list", "uchar", "int", "vertex_indices"]``)."""
    elements = []
    for line in header:
        words = line.split()
        if words[:1] == ["element"]:
            if len(words) != 3 or not words[2].isdigit():
                raise InputError(f"malformed PLY header line {line.strip()!r}", path=path)
            elements.append((words[1], int(words[2]), []))
        elif words[:1] == ["property"] and elements:
            elements[-1][2].append(words[1:])
    return elements
