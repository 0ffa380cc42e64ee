"""Read specimen scans in the formats scanners export, in metres, or refuse them in one line.

The formats and their libraries are in :mod:`airmat.calib.scan_readers` (one reader
per format, picked by suffix). This module adds what a calibration needs on
top: re-centring of georeferenced coordinates in float64 before anything
else, unit conversion to metres, dropping non-finite points (organized
depth-camera clouds hold NaN), area-weighted sampling of coarse meshes, the
quantization step of 32-bit coordinates, and checks that turn every bad file
into one clear :class:`airmat.errors.InputError` naming it: missing,
unreadable, empty, truncated, unsupported, too few points, or an extent no
specimen has (with the unit that would fix it, when one would).
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from airmat.errors import InputError
from airmat.units import SCAN_UNITS
from airmat.calib.scan_readers import SUPPORTED_SUFFIXES, read_cloud

__all__ = ["Scan", "read_scan", "SUPPORTED_SUFFIXES", "MIN_POINTS", "MIN_EXTENT", "MAX_EXTENT",
           "TYPICAL_EXTENT"]

log = logging.getLogger(__name__)

#: fewest finite points a scan must hold
MIN_POINTS = 100
#: smallest and largest plausible scan extent (robust bounding diagonal, m)
MIN_EXTENT = 0.020
MAX_EXTENT = 50.0
#: extents (m) a unit hint may lead to: a specimen and its surroundings, not a room or a survey
TYPICAL_EXTENT = (0.05, 5.0)
#: points the robust extent is measured on (a systematic subsample of larger scans)
_EXTENT_SAMPLE = 200_000
#: re-centre when the scan's centre is farther from the origin than this many extents
_RECENTRE_RATIO = 10.0


@dataclass(frozen=True)
class Scan:
    """A scan read from a file, in metres.

    Attributes
    ----------
    points : ndarray of shape (N, 3)
        Finite coordinates (m), float64, relative to ``offset``.
    path : str
        The file read.
    n_nonfinite_dropped : int
        Points dropped because a coordinate was NaN or infinite.
    kind : {"points", "mesh"}
        Whether the file held a point cloud or a mesh (faces).
    offset : ndarray of shape (3,)
        Subtracted from the file's coordinates (m), in float64 before any
        other step: zero, or a georeferenced scan's centre.
    quantization : float
        Step between neighbouring representable coordinates of a file that
        stores 32-bit floats, at its largest coordinate (m); 0 for others.
    units : str
        The unit the coordinates were read in.
    n_scans : int
        Scans in the file (several in a multi-scan E57).
    """

    points: np.ndarray
    path: str
    n_nonfinite_dropped: int
    kind: str
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    quantization: float = 0.0
    units: str = "mm"
    n_scans: int = 1


def read_scan(path: str | os.PathLike, *, units: str | None = None, n_mesh_samples: int = 200_000,
              seed=0, scan_index: int | None = None, specimen: bool = True) -> Scan:
    """Read a scan file and return its finite points in metres.

    Parameters
    ----------
    path : path
        A scan file with one of :data:`SUPPORTED_SUFFIXES`: PLY (points or
        mesh, any encoding), OBJ, STL, OFF, GLB/glTF, E57, LAS/LAZ, PCD,
        PTS/XYZ/TXT.
    units : {"m", "cm", "mm", "in"}, optional
        Unit of the file's coordinates. Default: the format's own (metres
        for E57 and LAS/LAZ), else millimetres.
    n_mesh_samples : int
        A mesh with fewer distinct vertices than this is coarse: it is sampled
        with this many points, area-weighted over its faces, instead of using
        its vertices.
    seed : int or numpy Generator
        Seed of the face sampling.
    scan_index : int, optional
        Scan of a multi-scan E57 to read; by default all of them, merged in
        one frame with their poses.
    specimen : bool
        Refuse an extent no specimen scan has (below :data:`MIN_EXTENT` or above
        :data:`MAX_EXTENT`), naming the unit that would fit. False for scans whose
        size is checked against something else (a built mattress, registered onto its
        design: :mod:`airmat.asbuilt.registration` detects the unit from the sizes).

    Returns
    -------
    Scan

    Raises
    ------
    airmat.errors.InputError
        With ``path`` set, when the file is missing or unreadable, empty,
        truncated, of an unsupported format, holds fewer than
        :data:`MIN_POINTS` finite points, or (with ``specimen``) its extent (robust
        bounding diagonal) is below :data:`MIN_EXTENT` or above :data:`MAX_EXTENT`
        after the unit conversion.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> xyz = np.random.default_rng(0).uniform(0, 300, (200, 3)) + [5e9, 4e9, 0]  # UTM, mm
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "utm.xyz"
    >>> np.savetxt(p, xyz, fmt="%.3f")
    >>> scan = read_scan(p)
    >>> bool(np.abs(scan.points).max() < 1.0), scan.offset.round(-3).tolist()
    (True, [5000000.0, 4000000.0, 0.0])
    """
    path = Path(path)
    if units is not None and units not in SCAN_UNITS:
        raise InputError(f"unknown scan unit {units!r}; use one of {', '.join(SCAN_UNITS)}", path=path)
    if path.is_dir():
        raise InputError("is a folder: give one scan file ('airmat calibrate' reads a folder's scans through "
                         "its manifest CSV)", path=path)
    if path.suffix.lower() not in SUPPORTED_SUFFIXES:
        raise InputError(f"unsupported scan format {path.suffix or '(no suffix)'!r}; "
                         f"use one of {', '.join(SUPPORTED_SUFFIXES)}", path=path)
    _check_file(path)
    raw = read_cloud(path, scan_index=scan_index)
    unit = units or raw.units or "mm"
    vertices, faces = raw.vertices, raw.faces
    kind = "mesh" if faces is not None and len(faces) else "points"
    # per column (strided 1-D reductions are several times faster than axis=0 on (N, 3))
    good = np.ones(len(vertices), bool) if np.isfinite(vertices).all() else np.isfinite(vertices).all(axis=1)
    finite = vertices if good.all() else vertices[good]
    lo, hi = (np.array([finite[:, j].min() for j in range(3)]), np.array([finite[:, j].max() for j in range(3)])) \
        if len(finite) else (np.zeros(3), np.zeros(3))
    offset = _offset(lo, hi)
    if offset.any():
        vertices = vertices - offset  # float64: exact to the file's own precision
    points, n_bad = _finite(vertices, faces, good, path, n_mesh_samples, seed)
    factor = SCAN_UNITS[unit]
    points = points * factor
    quant = _quantization(raw, lo, hi, len(finite)) * factor
    _check_count_and_extent(points, path, unit, n_bad=n_bad, explicit=units is not None,
                            format_units=raw.units is not None, extent=specimen)
    if n_bad:  # after the checks: a refused scan gets one line, not a warning too
        log.warning("%s: dropped %d of %d points with non-finite coordinates", path, n_bad, len(vertices))
    return Scan(points=points, path=str(path), n_nonfinite_dropped=n_bad, kind=kind, offset=offset * factor,
                quantization=quant, units=unit, n_scans=raw.n_scans)


def _check_file(path: Path) -> None:
    """Missing, not a file, unreadable or empty: one InputError naming it."""
    try:
        st = path.stat()
    except OSError as err:  # missing, a symlink loop, a name too long
        raise InputError("no such file" if not path.is_symlink() and not path.exists()
                         else f"cannot read: {err.strerror or err}", path=path) from None
    import stat

    if not stat.S_ISREG(st.st_mode):
        raise InputError("not a regular file", path=path)
    if st.st_size == 0:
        raise InputError("empty file", path=path)
    try:
        with open(path, "rb") as fh:
            fh.read(1)
    except OSError as err:
        raise InputError(f"cannot read: {err.strerror or err}", path=path) from None


def _offset(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The centre to subtract (file units), from the finite points' bounds: nonzero only far from the origin."""
    mid = 0.5 * (lo + hi)
    extent = float(np.linalg.norm(hi - lo))
    if np.linalg.norm(mid) <= _RECENTRE_RATIO * max(extent, np.finfo(float).tiny):
        return np.zeros(3)
    return np.round(mid)  # a whole number of file units: the stored offset reads back exactly


def _quantization(raw, lo, hi, n_finite) -> float:
    """Spacing of 32-bit floats at the file's largest coordinate, or the integer step of a scaled-integer
    format (LAS scale, E57 scaled integers), whichever is larger (file units); 0 for float64 files."""
    if not raw.float32 or not n_finite:
        return float(raw.step)
    largest = float(np.maximum(np.abs(lo), np.abs(hi)).max())
    return float(np.spacing(np.float32(largest)))


def _finite(vertices, faces, good, path, n_mesh_samples, seed):
    """Finite points: the vertices, or area-weighted samples on a coarse mesh."""
    n_bad = int(np.count_nonzero(~good))
    if faces is not None and len(faces):
        faces = faces[good[faces].all(axis=1)]
        # STL repeats each vertex per face; the count only decides fine vs coarse
        if len(faces) and np.count_nonzero(good) < n_mesh_samples:
            return _sample_faces(vertices, faces, n_mesh_samples, seed), n_bad
    return (vertices if not n_bad else vertices[good]), n_bad


def _sample_faces(vertices, faces, count, seed):
    """``count`` points area-weighted on the triangles (a coarse mesh)."""
    import trimesh

    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False, validate=False)
    points, _ = trimesh.sample.sample_surface(mesh, int(count), seed=seed)
    return np.asarray(points, dtype=float)


def _length(metres: float) -> str:
    """A specimen's extent as one prints it: metres from 1 m, millimetres below."""
    return f"{metres:.3g} m" if metres >= 1 else f"{metres * 1e3:.3g} mm"


def _check_count_and_extent(points, path, unit, *, n_bad, explicit, format_units, extent: bool = True):
    """Too few points, or an extent no specimen scan has.

    The hint names the ``--scan-units`` that reads the file as a typical specimen
    scan: as a question when the unit was a default, as an alternative when it
    was chosen; for a format that fixes its unit (E57, LAS) the message also says
    how large the scan is in that unit (a file written in another one).
    """
    n = len(points)
    if n < MIN_POINTS:
        dropped = f", {n_bad} of {n + n_bad} were NaN or infinite" if n_bad else ""
        raise InputError(f"only {n} finite points{dropped} (need at least {MIN_POINTS})",
                         path=path, n_points=n)
    if not extent:
        return
    step = max(n // _EXTENT_SAMPLE, 1)  # a systematic subsample: the bounds are a plausibility check
    lo, hi = np.percentile(points[::step], [0.5, 99.5], axis=0)
    extent = float(np.linalg.norm(hi - lo))
    if MIN_EXTENT <= extent <= MAX_EXTENT:
        return
    in_file = extent / SCAN_UNITS[unit]
    fits = [u for u, f in SCAN_UNITS.items() if u != unit and TYPICAL_EXTENT[0] <= in_file * f <= TYPICAL_EXTENT[1]]
    size = f"extent {extent * 1e3:.3g} mm" if extent < MIN_EXTENT else f"extent {extent:.3g} m"
    names = {"m": "metres", "cm": "centimetres", "mm": "millimetres", "in": "inches", "ft": "feet",
             "us-ft": "US survey feet"}
    fixed = format_units and not explicit   # the format's own unit (E57, LAS): a file written in another one
    if fixed and fits:
        other = in_file * SCAN_UNITS[fits[0]]
        raise InputError(f"{size}: not a specimen scan ({MIN_EXTENT * 1e3:g} mm to {MAX_EXTENT:g} m) the "
                         f"{path.suffix[1:].upper()} format is in {unit}; read as {names[fits[0]]} it is "
                         f"{_length(other)}: pass --scan-units {fits[0]}", path=path, extent=extent)
    if fits and not explicit:
        raise InputError(f"{size}: are the coordinates in {names[fits[0]]}? pass --scan-units {fits[0]}",
                         path=path, extent=extent)
    what = "large" if extent > MAX_EXTENT else "small"
    if fits:  # the user chose the unit; another one would fit
        raise InputError(f"{size} read in {unit}: too {what} for a specimen scan; pass --scan-units "
                         f"{fits[0]} if the file is in {fits[0]}", path=path, extent=extent)
    why = f"the {path.suffix[1:].upper()} format is in {unit}" if fixed else \
        f"in {unit} or any other unit ({', '.join(SCAN_UNITS)})"
    raise InputError(f"{size}: not a specimen scan ({MIN_EXTENT * 1e3:g} mm to {MAX_EXTENT:g} m) "
                     f"{why}", path=path, extent=extent)
