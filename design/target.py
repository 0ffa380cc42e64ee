"""Target surfaces S: loading (OBJ, PLY, STL, OFF, and Rhino's 3DM through
:mod:`airmat.design.target_3dm`) and validation.

A target is a triangle mesh in metres. Files are in millimetres unless told
otherwise (a .3dm file says its own units). Every problem a user can cause raises
:class:`airmat.errors.InputError` naming the file: missing or unreadable
file, empty mesh, warped quads and larger polygons, non-manifold edges, NaN/inf
coordinates, several separate sheets or a closed solid
(:mod:`airmat.design.target_pieces`), and a size that does not fit the mattress
(a units slip).

A quad can be split along either diagonal and where it is warped the two
choices are different surfaces: quads flat enough for the choice not to matter
are split, more warped ones and larger polygons refused, asking for the
triangulation the user means (:mod:`airmat.design.target_polygons`).
"""

from __future__ import annotations

import logging
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from airmat.errors import InputError
from airmat.geometry.topology import edge_counts
from airmat.units import SCAN_UNITS
from airmat.calib.scan_readers.cut_short import check_complete, complete_binary_stl
from airmat.calib.scan_readers.obj_indices import check_obj_indices
from airmat.calib.scan_readers.ply_header import ply_renamed_xyz, ply_vertex_float32, ply_xyz_fields
from airmat.calib.scan_readers.raw import library_message
from airmat.design.target_pieces import check_one_sheet
from airmat.summary import Summarized

__all__ = ["Target", "load_target", "check_scale", "FORMATS", "UNITS"]

log = logging.getLogger(__name__)

FORMATS = ("obj", "ply", "stl", "off", "3dm")
#: metres per file unit
UNITS = {**SCAN_UNITS, "cm": 0.01}
#: target bounding diagonal / mattress diagonal outside this range is a units slip
SCALE_RANGE = (0.2, 50.0)


@dataclass(frozen=True, eq=False, repr=False)
class Target(Summarized):
    """A target surface S: a triangle mesh in metres.

    Parameters
    ----------
    vertices : ndarray of shape (n, 3)
        Vertex positions (m), finite.
    faces : ndarray of shape (m, 3)
        Triangles (vertex indices). Their winding gives the target's normals;
        the mattress's top face is placed on the side these normals point to.
    name : str
        For messages and outputs.
    units : str, default "m"
        The units the mesh was read in (its coordinates here are always metres);
        used to suggest the right units when the size does not fit the mattress.

    Raises
    ------
    airmat.errors.InputError
        For an empty mesh, wrong shapes, indices out of range, NaN/inf
        vertices or non-manifold edges (the count is in ``err.data``), and
        for several separate sheets or a closed surface
        (:func:`airmat.design.target_pieces.check_one_sheet`).
    """

    vertices: np.ndarray
    faces: np.ndarray
    name: str = "target"
    units: str = "m"


    def _summary(self):
        lo, hi = self.vertices.min(axis=0), self.vertices.max(axis=0)
        return f"Target {self.name}", [("vertices", len(self.vertices)), ("faces", len(self.faces)),
                                       ("extent", " x ".join(f"{x * 1e3:.0f}" for x in hi - lo) + " mm")]

    def __post_init__(self):
        v = np.asarray(self.vertices, dtype=float)
        f = np.asarray(self.faces)
        _check_mesh(v, f)
        check_one_sheet(v, f)
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "faces", f.astype(np.int64))

    @classmethod
    def from_mesh(cls, mesh, *, name: str | None = None) -> "Target":
        """The target of any mesh object with ``vertices`` (m) and ``faces`` (and optionally ``name``).

        E.g. an analytic surface of :mod:`airmat.synthetic.targets` or a ``trimesh.Trimesh`` in metres.
        A Target is returned as it is (unless ``name`` renames it).

        Parameters
        ----------
        mesh : object
            With ``vertices`` of shape (n, 3) (m) and ``faces`` of shape (m, 3).
        name : str, optional
            Default: ``mesh.name``, else ``"target"``.

        Raises
        ------
        airmat.errors.InputError
            When ``mesh`` has no vertices or faces, or they are not a valid mesh.

        Examples
        --------
        >>> from types import SimpleNamespace
        >>> t = Target.from_mesh(SimpleNamespace(vertices=np.eye(3), faces=[[0, 1, 2]], name="tri"))
        >>> t.name, t.faces.dtype
        ('tri', dtype('int64'))
        """
        if isinstance(mesh, cls) and name is None:
            return mesh
        if not (hasattr(mesh, "vertices") and hasattr(mesh, "faces")):
            raise InputError(f"a target needs vertices and faces, got a {type(mesh).__name__}")
        return cls(mesh.vertices, mesh.faces, name=name or getattr(mesh, "name", None) or "target",
                   units=getattr(mesh, "units", "m") if isinstance(mesh, cls) else "m")

    @property
    def bbox_diagonal(self) -> float:
        """Length (m) of the axis-aligned bounding box diagonal."""
        used = np.zeros(len(self.vertices), bool)
        used[self.faces.ravel()] = True
        return float(np.linalg.norm(np.ptp(self.vertices[used], axis=0)))

    @property
    def face_areas(self) -> np.ndarray:
        """Areas (m²) of the faces, shape (m,)."""
        return 0.5 * np.linalg.norm(self.face_cross, axis=1)

    @property
    def face_cross(self) -> np.ndarray:
        """Cross products of the faces' edge vectors (m²), shape (m, 3): twice area × normal."""
        p = self.vertices[self.faces]
        return np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])


def _check_mesh(v: np.ndarray, f: np.ndarray, topology: bool = True) -> None:
    """Refuse what is not a triangle mesh with a surface; with ``topology`` also faces that name a vertex
    twice and edges shared by more than two faces."""
    if v.ndim != 2 or v.shape[1] != 3:
        raise InputError(f"target vertices have shape {v.shape}, expected (n, 3)")
    if f.size == 0 or len(v) == 0:
        raise InputError(f"empty mesh: {len(v)} vertices and {len(f) if f.ndim else 0} faces "
                         "(a point cloud or a file without a surface?)")
    if f.ndim != 2 or f.shape[1] != 3:
        raise InputError(f"target faces have shape {f.shape}, expected (m, 3) triangles")
    if not np.issubdtype(f.dtype, np.integer) or f.min() < 0 or f.max() >= len(v):
        raise InputError(f"face indices must be integers in [0, {len(v) - 1}]")
    bad = ~np.isfinite(v).all(axis=1)
    if bad.any():
        raise InputError(f"{int(bad.sum())} of {len(v)} vertices have NaN or infinite coordinates "
                         f"(first: vertex {int(np.flatnonzero(bad)[0])})", n_bad=int(bad.sum()))
    _check_area(v, f)
    if not topology:
        return
    repeated = _repeats_a_vertex(f)
    if repeated.any():
        raise InputError(f"{int(repeated.sum())} of {len(f)} faces repeat a vertex (first: face "
                         f"{int(np.flatnonzero(repeated)[0])}): they have no surface; drop them",
                         n_repeated=int(repeated.sum()))
    _, counts = edge_counts(f)
    n_nm = int((counts > 2).sum())
    if n_nm:
        raise InputError(f"mesh has {n_nm} non-manifold edges (shared by more than two faces); "
                         "the target must be a single-sheeted surface", n_nonmanifold=n_nm)


def _repeats_a_vertex(f: np.ndarray) -> np.ndarray:
    """Faces (m,) bool that name one vertex twice: a segment or a point, no surface."""
    return (f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 0] == f[:, 2])


def _without_empty_faces(vertices: np.ndarray, faces: np.ndarray) -> tuple:
    """``faces`` without those that repeat a vertex and without second copies of a face (any order or
    winding), then ``vertices`` without those no face uses: (vertices, faces, faces dropped).

    A modeller's export can hold such faces (a sliver whose corners merge, a face written twice); they
    add no surface, but their edges would count as shared by more than two faces."""
    keep = ~_repeats_a_vertex(faces)
    _, first = np.unique(np.sort(faces, axis=1), axis=0, return_index=True)
    once = np.zeros(len(faces), bool)
    once[first] = True
    keep &= once
    used = np.zeros(len(vertices), bool)
    used[faces[keep].ravel()] = True
    index = np.cumsum(used) - 1
    return vertices[used], index[faces[keep]], int((~keep).sum())


#: a target whose faces cover less than this fraction of its bounding diagonal squared has no surface
MIN_AREA_FRACTION = 1e-6


def _check_area(v: np.ndarray, f: np.ndarray) -> None:
    """Refuse collinear points and meshes whose faces are all degenerate (no surface to design for)."""
    p = v[f]
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    diag2 = float(np.sum((v.max(axis=0) - v.min(axis=0)) ** 2))
    n_degenerate = int(np.sum(area <= 1e-12 * diag2))
    if not area.sum() > MIN_AREA_FRACTION * diag2:
        raise InputError(f"the target has no surface: {n_degenerate} of {len(f)} faces are degenerate "
                         f"(zero area; collinear or coincident points)", n_degenerate=n_degenerate)


#: float32 coordinates rounded to more than this fraction of the median edge are refused
FLOAT32_STEP_FRACTION = 0.01


def _stored_float32(path: Path) -> bool:
    """Whether the file stores its coordinates as 32-bit floats (a float PLY, a binary STL)."""
    ext = path.suffix.lower()
    if ext == ".ply":
        return ply_vertex_float32(path)
    return ext == ".stl" and complete_binary_stl(path)


def _check_float32_rounding(path: Path, v: np.ndarray, f: np.ndarray, units: str) -> None:
    """Refuse float32 coordinates so far from the origin that their rounding is coarse against the edges.

    A georeferenced model (millions of mm from the origin) saved as float PLY or binary STL
    keeps only about 7 digits: at 4.2e9 mm the step is 512 mm, vertices merge, and the
    mesh was refused as "1018 non-manifold edges".
    """
    big = float(np.abs(v).max())
    step = float(np.spacing(np.float32(big)))
    # the typical edge from the bounding box and the face count: the rounded edges themselves are not to be trusted
    edge = float(np.linalg.norm(np.ptp(v[f.ravel()], axis=0))) / np.sqrt(len(f) / 2)
    if step > FLOAT32_STEP_FRACTION * edge:
        raise InputError(f"its 32-bit float coordinates reach {big:.3g} {units} from the origin, where they are "
                         f"rounded to steps of {step:.3g} {units}, against edges of about {edge:.2g} {units}: move the "
                         "model near the origin before exporting, or export double precision (PLY double, OBJ)",
                         path=path, float32_step=step, typical_edge=edge)


def _declared_polygons(path: Path, mesh) -> int | None:
    """Number of faces the file declares (polygons of any size), or None when unknown."""
    ext = path.suffix.lower().lstrip(".")
    if ext == "ply":
        raw = mesh.metadata.get("_ply_raw", {}).get("face")
        return None if raw is None else int(raw["length"])
    if ext == "obj":
        return len(re.findall(rb"(?m)^[ \t]*f[ \t]", path.read_bytes()))
    if ext == "off":
        text = re.sub(rb"#[^\n]*", b"", path.read_bytes())
        tokens = text.split(maxsplit=4)
        return int(tokens[2]) if len(tokens) > 3 and tokens[0].endswith(b"OFF") else None
    return None  # STL holds triangles only


def load_target(path, *, units: str = "mm", name: str | None = None, mattress=None) -> Target:
    """Read a target surface from an OBJ, PLY, STL, OFF or Rhino 3DM file.

    Parameters
    ----------
    path : str or Path
        The mesh file; the format is taken from the extension.
    units : {"mm", "m", "cm", "in", "ft", "us-ft"}, default "mm"
        Units of the file's coordinates (a .3dm file's own model units take precedence).
    name : str, optional
        Name of the target (default: the file's stem).
    mattress : airmat.design.mattress.Mattress, optional
        When given, also check that the target's size fits the mattress
        (:func:`check_scale`).

    Returns
    -------
    Target
        Vertices in metres; coincident vertices (STL) are merged, then faces that name a vertex twice
        and second copies of a face are dropped (they hold no surface), with the vertices only they used.

    Raises
    ------
    airmat.errors.InputError
        With ``path`` set: missing or unreadable file, a file cut short
        (:mod:`airmat.calib.scan_readers.cut_short`), unknown format or
        units, empty mesh, non-triangle faces, NaN/inf coordinates,
        non-manifold edges, several sheets or a closed surface, a size
        that does not fit the mattress.
    """
    import trimesh

    path = Path(path)
    if units not in UNITS:
        raise InputError(f"unknown units {units!r}: use one of {', '.join(UNITS)}", path=path)
    ext = path.suffix.lower().lstrip(".")
    if path.is_dir():
        raise InputError(f"is a folder: give the target's mesh file ({', '.join('.' + f for f in FORMATS)})",
                         path=path)
    if ext not in FORMATS:
        raise InputError(f"unsupported target format {path.suffix!r}: use one of "
                         f"{', '.join('.' + f for f in FORMATS)}", path=path)
    if not path.is_file():
        raise InputError("target file not found", path=path)
    if ext == "3dm":
        return _load_3dm(path, units, name, mattress)
    check_complete(path)   # a file cut short would otherwise give part of the surface, or a cryptic error
    if ext == "obj":
        check_obj_indices(path)
    source = path
    if ext == "ply":
        fields = ply_xyz_fields(path)
        if fields != ("x", "y", "z"):     # X Y Z: trimesh reads lower-case names only
            source = ply_renamed_xyz(path, fields)
    try:
        mesh = trimesh.load(source, file_type=ext, process=False, force="mesh")
        declared = _declared_polygons(path, mesh)
    except (ValueError, KeyError, IndexError, TypeError, OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the target as {ext.upper()} (corrupt?): {library_message(exc)}",
                         path=path) from exc
    vertices = np.asarray(getattr(mesh, "vertices", np.zeros((0, 3))), dtype=float)
    faces = np.asarray(getattr(mesh, "faces", np.zeros((0, 3), int)))
    polygons = declared is not None and 0 < declared < len(faces)
    try:
        if polygons:                  # the file's own polygons: flat quads split, others refused
            vertices, faces = _file_polygons(path, ext, mesh, vertices)
        _check_mesh(vertices, faces, topology=False)  # NaNs before merging, which would hide them
        if _stored_float32(path):     # before merging too: the rounding merges vertices
            _check_float32_rounding(path, vertices, faces, units)
        return _target(path, vertices, faces, units, name, mattress)
    except InputError as err:
        raise err.with_path(path)


def _target(path: Path, vertices: np.ndarray, faces: np.ndarray, units: str, name: str | None, mattress) -> Target:
    """The Target of a file's vertices (in ``units``) and triangles: coincident vertices merged, faces without
    surface dropped (:func:`_without_empty_faces`), its size checked against ``mattress``."""
    merged, kept, dropped = _without_empty_faces(*_merged(vertices, faces))
    if dropped:
        log.info("target %s: %d faces without surface dropped (a vertex named twice, or a face written twice)",
                 path.name, dropped)
    target = Target(merged * UNITS[units], kept, name=name or path.stem, units=units)
    if mattress is not None:
        check_scale(target, mattress)
    log.info("target %s: %d vertices, %d faces (%s), bounding diagonal %.0f mm", target.name, len(target.vertices),
             len(target.faces), units, 1e3 * target.bbox_diagonal)
    return target


def _file_polygons(path: Path, ext: str, mesh, vertices: np.ndarray) -> tuple:
    """The vertices and triangles of a file with quads (:mod:`airmat.design.target_polygons`): an OBJ's and an OFF's
    from their own lines, a PLY's from the face list trimesh keeps."""
    from airmat.design.target_polygons import obj_polygons, off_polygons, ply_polygons, triangulated

    if ext == "obj":
        vertices, polygons = obj_polygons(path.read_bytes())
    elif ext == "off":
        vertices, polygons = off_polygons(path.read_bytes())
    else:
        polygons = ply_polygons(mesh)
        if polygons is None:
            raise InputError("the mesh has non-triangle faces that could not be read as polygons; triangulate it "
                             "first (e.g. Blender: Triangulate Faces)")
    return vertices, triangulated(vertices, polygons)


def _load_3dm(path: Path, units: str, name: str | None, mattress) -> Target:
    """:func:`load_target` of a Rhino file (:mod:`airmat.design.target_3dm`): in its own model units (``units``
    where it has none)."""
    from airmat.design.target_3dm import read_3dm

    try:
        vertices, faces, own = read_3dm(path)
        _check_mesh(vertices, faces, topology=False)
        return _target(path, vertices, faces, own or units, name, mattress)
    except InputError as err:
        raise err.with_path(path)


def _merged(vertices: np.ndarray, faces: np.ndarray) -> tuple:
    """Coincident vertices merged (trimesh's ``merge_vertices``): (vertices, faces)."""
    import trimesh

    mesh = trimesh.Trimesh(vertices, faces, process=False)
    mesh.merge_vertices()
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def check_scale(target: Target, mattress) -> None:
    """Refuse a target whose size does not fit the mattress: a units slip.

    The target's bounding diagonal must be between 0.2 and 50 times the
    mattress's diagonal.

    Parameters
    ----------
    target : Target
        Its ``units`` (those it was read in) let the message suggest the right ones.
    mattress : airmat.design.mattress.Mattress

    Raises
    ------
    airmat.errors.InputError
        Saying how large the target is, compared with the mattress, and which
        units would make it fit.
    """
    ratio = target.bbox_diagonal / mattress.diagonal
    if SCALE_RANGE[0] <= ratio <= SCALE_RANGE[1]:
        return
    units = target.units
    scale = UNITS.get(units, 1.0)
    # the units under which the target would be about as large as the mattress (ratio ~ 1.5)
    guess = min(UNITS, key=lambda u: abs(math.log(ratio * UNITS[u] / scale / 1.5)))
    size = "larger" if ratio > 1 else "smaller"
    hint = f"; it looks like the file is in {guess}, not {units}" if guess != units else ""
    raise InputError(f"target is {ratio:.3g}× the mattress diagonal ({1e3 * target.bbox_diagonal:.4g} mm "
                     f"vs {1e3 * mattress.diagonal:.0f} mm): far {size} than the "
                     f"{mattress.size_mm} mattress{hint}", ratio=ratio, guessed_units=guess)
