"""Read specimen scans: PLY point clouds in any encoding, and PLY/OBJ/STL/OFF meshes.

trimesh parses the files (every PLY encoding, float or double, extra
properties such as colour or confidence). This module adds what a
calibration needs on top: unit conversion to metres, dropping non-finite
points (organized depth-camera clouds hold NaN), area-weighted sampling of
coarse meshes, and checks that turn every bad file into one clear
:class:`airmat.errors.InputError` naming it: missing, empty, truncated,
unsupported, too few points, or a size that says the units are wrong.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from airmat.errors import InputError
from airmat.units import SCAN_UNITS

__all__ = ["Scan", "read_scan", "SUPPORTED_SUFFIXES", "MIN_POINTS", "MIN_EXTENT", "MAX_EXTENT"]

log = logging.getLogger(__name__)

#: file suffixes read_scan understands (trimesh file types)
SUPPORTED_SUFFIXES = (".ply", ".obj", ".stl", ".off", ".xyz")
#: fewest finite points a scan must hold
MIN_POINTS = 100
#: smallest and largest plausible scan extent (robust bounding diagonal, m)
MIN_EXTENT = 0.020
MAX_EXTENT = 50.0


@dataclass(frozen=True)
class Scan:
    """A scan read from a file, in metres.

    Attributes
    ----------
    points : ndarray of shape (N, 3)
        Finite coordinates (m), float64.
    path : str
        The file read.
    n_nonfinite_dropped : int
        Points dropped because a coordinate was NaN or infinite.
    kind : {"points", "mesh"}
        Whether the file held a point cloud or a mesh (faces).
    """

    points: np.ndarray
    path: str
    n_nonfinite_dropped: int
    kind: str


def read_scan(path: str | os.PathLike, *, units: str = "mm", n_mesh_samples: int = 200_000,
              seed=0) -> Scan:
    """Read a scan file and return its finite points in metres.

    Parameters
    ----------
    path : path
        A ``.ply`` (points or mesh, any encoding), ``.obj``, ``.stl``, ``.off``
        or ``.xyz`` file.
    units : {"m", "mm", "in"}
        Unit of the file's coordinates (default millimetres).
    n_mesh_samples : int
        A mesh with fewer distinct vertices than this is coarse: it is sampled
        with this many points, area-weighted over its faces, instead of using
        its vertices.
    seed : int or numpy Generator
        Seed of the face sampling.

    Returns
    -------
    Scan

    Raises
    ------
    airmat.errors.InputError
        With ``path`` set, when the file is missing or unreadable, empty,
        truncated, of an unsupported format, holds fewer than
        :data:`MIN_POINTS` finite points, or its extent (robust bounding
        diagonal) is below :data:`MIN_EXTENT` or above :data:`MAX_EXTENT`
        after the unit conversion (wrong ``units``).
    """
    path = Path(path)
    if units not in SCAN_UNITS:
        raise InputError(f"unknown scan unit {units!r}; use one of {', '.join(SCAN_UNITS)}", path=path)
    suffix = path.suffix.lower()
    if suffix not in SUPPORTED_SUFFIXES:
        raise InputError(f"unsupported scan format {suffix or '(no suffix)'!r}; "
                         f"use one of {', '.join(SUPPORTED_SUFFIXES)}", path=path)
    if not path.is_file():
        raise InputError("no such file" if not path.exists() else "not a regular file", path=path)
    if path.stat().st_size == 0:
        raise InputError("empty file", path=path)
    if suffix == ".ply":
        _check_ply_complete(path)
    geometry = _load(path, suffix)
    vertices, faces = _vertices_faces(geometry, path)
    kind = "mesh" if faces is not None and len(faces) else "points"
    points, n_bad = _finite(vertices, faces, path, n_mesh_samples, seed)
    points = points * SCAN_UNITS[units]
    _check_count_and_extent(points, path, units)
    return Scan(points=points, path=str(path), n_nonfinite_dropped=n_bad, kind=kind)


def _load(path: Path, suffix: str):
    import trimesh

    try:
        with open(path, "rb") as fh:
            return trimesh.load(fh, file_type=suffix[1:], process=False)
    except OSError as err:
        raise InputError(f"cannot read: {err.strerror or err}", path=path) from err
    except Exception as err:  # trimesh raises many types for malformed files
        raise InputError(f"cannot parse {suffix[1:].upper()} file (truncated or corrupt?): "
                         f"{type(err).__name__}: {err}", path=path) from err


def _vertices_faces(geometry, path: Path):
    """(V, 3) float64 vertices and (F, 3) faces or None, from a trimesh object."""
    import trimesh

    if isinstance(geometry, trimesh.Scene):
        parts = [g for g in geometry.geometry.values() if hasattr(g, "vertices") and len(g.vertices)]
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
    return vertices, (None if faces is None else np.asarray(faces))


def _finite(vertices, faces, path, n_mesh_samples, seed):
    """Finite points: the vertices, or area-weighted samples on a coarse mesh."""
    good = np.isfinite(vertices).all(axis=1)
    n_bad = int(np.count_nonzero(~good))
    if n_bad:
        log.warning("%s: dropped %d of %d points with non-finite coordinates", path, n_bad, len(vertices))
    if faces is not None and len(faces):
        faces = faces[good[faces].all(axis=1)]
        # STL repeats each vertex per face; the count only decides fine vs coarse
        if len(faces) and np.count_nonzero(good) < n_mesh_samples:
            return _sample_faces(vertices, faces, n_mesh_samples, seed), n_bad
    return vertices[good], n_bad


def _sample_faces(vertices, faces, count, seed):
    """``count`` points area-weighted on the triangles (a coarse mesh)."""
    import trimesh

    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False, validate=False)
    points, _ = trimesh.sample.sample_surface(mesh, int(count), seed=seed)
    return np.asarray(points, dtype=float)


def _check_count_and_extent(points, path, units):
    n = len(points)
    if n < MIN_POINTS:
        raise InputError(f"only {n} finite points (need at least {MIN_POINTS})", path=path, n_points=n)
    lo, hi = np.percentile(points, [0.5, 99.5], axis=0)
    extent = float(np.linalg.norm(hi - lo))
    if extent < MIN_EXTENT:
        hint = "are the coordinates in metres? pass --scan-units m" if units != "m" else \
            "is this a scan of a specimen?"
        raise InputError(f"extent {extent * 1e3:.3g} mm: {hint}", path=path, extent=extent)
    if extent > MAX_EXTENT:
        hint = "are the coordinates in millimetres? pass --scan-units mm" if units != "mm" else \
            "is this a scan of a specimen? (check --scan-units)"
        raise InputError(f"extent {extent:.3g} m: {hint}", path=path, extent=extent)


def _check_ply_complete(path: Path) -> None:
    """Raise InputError when a PLY header is missing or the body is cut short.

    trimesh notices most truncations, but silently accepts an ascii body cut
    inside its last line; this checks the header's element counts against
    the body (byte size for binary, the last line of each element for ascii).
    """
    with open(path, "rb") as fh:
        head = fh.read(1 << 16)
        end = head.find(b"end_header")
        if not head.startswith(b"ply") or end < 0:
            raise InputError("not a PLY file (no 'ply ... end_header' header)", path=path)
        body_start = head.index(b"\n", end) + 1 if b"\n" in head[end:] else len(head)
        header = head[:body_start].decode("ascii", errors="replace").split("\n")
        elements = _ply_elements(header, path)
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


def _ply_elements(header, path):
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
