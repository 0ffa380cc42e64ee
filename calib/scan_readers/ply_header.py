"""PLY header checks: complete body, and whether the vertex coordinates are 32-bit floats."""

from __future__ import annotations

from pathlib import Path

from airmat.errors import InputError

__all__ = ["check_ply_complete", "ply_elements", "ply_vertex_float32"]


def ply_vertex_float32(path: Path) -> bool:
    """Whether a PLY file's vertex ``x`` property is a 32-bit float."""
    with open(path, "rb") as fh:
        head = fh.read(1 << 16)
    end = head.find(b"end_header")
    in_vertex = False
    for line in head[:end].decode("ascii", errors="replace").split("\n"):
        words = line.split()
        if words[:1] == ["element"]:
            in_vertex = words[1:2] == ["vertex"]
        elif in_vertex and words[:1] == ["property"] and words[-1:] == ["x"]:
            return words[1] in ("float", "float32")
    return False


def check_ply_complete(path: Path) -> None:
    """Raise InputError when a PLY header is missing or the body is cut short.

    trimesh notices most truncations, but silently accepts an ascii body cut
    inside its last line; this checks the header's element counts against
    the body (byte size for binary, the last line of each element for ascii).
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
            return  # binary: trimesh checks the byte count itself
        fh.seek(body_start)
        lines = fh.read().decode("ascii", errors="replace").split("\n")
    lines = [ln for ln in lines if ln.strip()]
    start = 0
    for name, count, props in elements:
        if count == 0:
            continue
        last = start + count - 1
        if last >= len(lines):
            raise InputError(f"truncated PLY: element {name!r} declares {count} rows, "
                             f"the file has {max(len(lines) - start, 0)}", path=path)
        tokens = lines[last].split()
        if all(not p.startswith("list") for p in props) and len(tokens) != len(props):
            raise InputError(f"truncated PLY: last {name!r} row has {len(tokens)} values, "
                             f"expected {len(props)}", path=path)
        start += count


def ply_elements(header, path):
    """[(name, count, [property type strings])] from PLY header lines."""
    elements = []
    for line in header:
        words = line.split()
        if words[:1] == ["element"]:
            if len(words) != 3 or not words[2].isdigit():
                raise InputError(f"malformed PLY header line {line.strip()!r}", path=path)
            elements.append((words[1], int(words[2]), []))
        elif words[:1] == ["property"] and elements:
            elements[-1][2].append(" ".join(words[1:-1]))
    return elements
