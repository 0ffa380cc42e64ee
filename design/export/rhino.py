"""``design.3dm`` / ``inflated.3dm``: the design for Rhino and Grasshopper (rhino3dm, units mm).

Layers (full paths; ``FACE/FAMILY`` is ``top/k1``, ``top/k2``, ``bottom/k1``, ``bottom/k2``)::

    S_hat                     Ŝ as a mesh, in the target's frame
    S_hat::FACE/FAMILY        each string as a 3D polyline on the face it is tied on (its Ω polyline lifted
                              through Ŝ's Ω coordinates, then offset by half the thickness along Ŝ's top
                              normal: + for top strings, - for bottom ones)
    S_hat::ties               the tie points, on their face likewise
    omega                     the mattress outline on Ω = [0, W] × [0, H] (z = 0; the cutting list's coordinates)
    omega::FACE/FAMILY        each string as a flat polyline on Ω (top face seen from above, as in design.json)
    omega::ties               the tie points on Ω
    inflated::median          (inflated.3dm) the simulated median shape aligned to Ŝ, on Ŝ's triangles
    inflated::lo95, ::hi95    (inflated.3dm) the envelope shapes, on hidden layers
    monte_carlo::p95          (inflated.3dm with a Monte-Carlo) Ŝ with vertex colours of each vertex's 95 %
                              deviation quantile over the samples (viridis, :func:`band_colours`), on a
                              hidden layer; its user text gives the scale's ends in mm

Every string curve is named by its id and carries the user text of :data:`STRING_KEYS`
(lengths in mm, κ in 1/m, face, family, and the grid nodes of its ends when the
design has them). Ŝ is the mattress's mid-surface; the lifted polylines and tie points lie
on the face their string is tied on, Ŝ ± t/2 n (:func:`lift_to_face`).
rhino3dm adds mesh vertices one by one (it has no bulk setter); the file is
written to memory and published with :mod:`airmat.atomic`.

Layer and object GUIDs are derived from their names (uuid5), so the same design
gives the same model, and :mod:`airmat.design.export.rhino_stable` removes what
OpenNURBS stamps from the run (the time, the user name, the file name): the same
design gives the same bytes.
"""

from __future__ import annotations

import logging
import uuid
from pathlib import Path

import numpy as np

from airmat.atomic import atomic_write_bytes
from airmat.errors import InputError
from airmat.units import M_TO_MM
from airmat.design.export.rhino_stable import stable_3dm_bytes

__all__ = ["lift_to_surface", "lift_to_face", "band_colours", "rhino_model", "write_3dm", "rhino3dm_available", "STRING_KEYS",
           "FACE_FAMILIES"]

FACE_FAMILIES = ("top/k1", "top/k2", "bottom/k1", "bottom/k2")
#: user text of every string curve
STRING_KEYS = ("id", "face", "family", "l_median_mm", "l_lo95_mm", "l_hi95_mm", "kappa_per_m", "L_mm",
               "a_node", "b_node")
_NAMESPACE = uuid.UUID("6f1c2a8e-4d0b-5e7a-9c3f-2b8d1e0a7c55")   # airmat's: ids are uuid5(this, path)
_COLOURS = {"top/k1": (220, 30, 30), "top/k2": (30, 60, 220), "bottom/k1": (240, 140, 0),
            "bottom/k2": (0, 170, 170)}


def lift_to_surface(points_uv: np.ndarray, xyz: np.ndarray, uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Points of Ω carried onto Ŝ by the linear map of the triangle that holds them.

    Parameters
    ----------
    points_uv : ndarray of shape (k, 2)
        Points on Ω (any length unit, the same as ``uv``).
    xyz : ndarray of shape (n, 3)
        Ŝ's vertices.
    uv : ndarray of shape (n, 2)
        Their Ω coordinates.
    faces : ndarray of shape (m, 3)
        Triangles shared by Ŝ and Ω.

    Returns
    -------
    ndarray of shape (k, 3)
        Barycentric interpolation of ``xyz``; points outside Ω (rounding at
        its edge) are moved onto Ω first, and any still unlocated take the
        nearest vertex.

    Examples
    --------
    >>> uv = np.array([[0., 0.], [1., 0.], [0., 1.]])
    >>> xyz = np.array([[0., 0., 0.], [2., 0., 0.], [0., 2., 1.]])
    >>> lift_to_surface(np.array([[0.5, 0.25]]), xyz, uv, np.array([[0, 1, 2]])).round(3).tolist()
    [[1.0, 0.5, 0.25]]
    """
    from matplotlib.tri import Triangulation

    points_uv = np.asarray(points_uv, float).reshape(-1, 2)
    if xyz.shape[1:] != (3,) or uv.shape != (len(xyz), 2):
        raise ValueError(f"xyz must be (n, 3) and uv (n, 2), got {xyz.shape} and {uv.shape}")
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    eps = 1e-9 * float(np.linalg.norm(hi - lo))
    p = np.clip(points_uv, lo + eps, hi - eps)
    tri = Triangulation(uv[:, 0], uv[:, 1], faces)
    t = tri.get_trifinder()(p[:, 0], p[:, 1])
    out = np.empty((len(p), 3))
    ok = t >= 0
    corners = uv[faces[t[ok]]]                                          # (k, 3, 2)
    e1, e2, d = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0], p[ok] - corners[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    b1 = (d[:, 0] * e2[:, 1] - d[:, 1] * e2[:, 0]) / det
    b2 = (e1[:, 0] * d[:, 1] - e1[:, 1] * d[:, 0]) / det
    bary = np.stack([1 - b1 - b2, b1, b2], axis=1)
    out[ok] = np.einsum("kj,kjd->kd", bary, xyz[faces[t[ok]]])
    if not ok.all():
        near = np.argmin(((p[~ok, None, :] - uv[None]) ** 2).sum(-1), axis=1)
        out[~ok] = xyz[near]
    return out


def _layer(model, name: str, colour=(0, 0, 0), parent=None, visible: bool = True) -> int:
    import rhino3dm as r

    layer = r.Layer()
    layer.Name = name
    layer.Color = (*colour, 255)
    layer.Visible = visible
    path = name
    if parent is not None:
        layer.ParentLayerId = model.Layers.FindIndex(parent).Id
        path = f"{model.Layers.FindIndex(parent).Name}::{name}"
    layer.Id = uuid.uuid5(_NAMESPACE, "layer " + path)
    return model.Layers.Add(layer)


def _attributes(layer: int, name: str, text: dict | None = None):
    import rhino3dm as r

    attr = r.ObjectAttributes()
    attr.LayerIndex = layer
    attr.Name = name
    attr.Id = uuid.uuid5(_NAMESPACE, f"object {layer} {name}")
    for key, value in (text or {}).items():
        attr.SetUserString(key, str(value))
    return attr


def _mesh(xyz_mm: np.ndarray, faces: np.ndarray):
    import rhino3dm as r

    mesh = r.Mesh()
    for x, y, z in xyz_mm.tolist():
        mesh.Vertices.Add(x, y, z)
    for a, b, c in faces.tolist():
        mesh.Faces.AddFace(a, b, c)
    mesh.Normals.ComputeNormals()
    return mesh


def band_colours(values: np.ndarray) -> tuple:
    """Viridis colours of ``values`` on a linear scale from their minimum to their maximum.

    Parameters
    ----------
    values : ndarray of shape (n,)

    Returns
    -------
    colours : ndarray of shape (n, 3) of uint8
        RGB; all the lowest colour when the values do not vary.
    lo, hi : float
        The values at the scale's ends.

    Examples
    --------
    >>> c, lo, hi = band_colours(np.array([2.0, 4.0, 3.0]))
    >>> c[0].tolist(), c[1].tolist(), (lo, hi)
    ([68, 1, 84], [253, 231, 37], (2.0, 4.0))
    """
    from matplotlib import colormaps

    values = np.asarray(values, float).reshape(-1)
    lo, hi = (float(values.min()), float(values.max())) if values.size else (0.0, 0.0)
    t = (values - lo) / (hi - lo) if hi > lo else np.zeros_like(values)
    rgb = colormaps["viridis"](t)[:, :3]
    return np.round(rgb * 255).astype(np.uint8), lo, hi


def _band_mesh(xyz_mm: np.ndarray, faces: np.ndarray, colours: np.ndarray):
    mesh = _mesh(xyz_mm, faces)
    for c in colours.tolist():              # rhino3dm has no bulk setter
        mesh.VertexColors.Add(*c)
    return mesh


def _polyline(points) :
    import rhino3dm as r

    return r.PolylineCurve([r.Point3d(*p) for p in points])


def _node(dash: dict, end: str) -> str:
    node = dash.get(f"{end}_node")
    if not node:
        return "free (no tie grid)"
    return f"row {node['row']} col {node['col']} ({node['u_mm']:g}, {node['v_mm']:g} mm)"


def string_text(dash: dict) -> dict:
    """The user text of one string (see :data:`STRING_KEYS`) from its design.json entry."""
    l = dash["l_mm"]
    return {"id": dash["id"], "face": dash["side"], "family": dash["family"],
            "l_median_mm": f"{l['median']:.2f}", "l_lo95_mm": f"{l['lo95']:.2f}", "l_hi95_mm": f"{l['hi95']:.2f}",
            "kappa_per_m": f"{dash['kappa_per_m']:.4f}", "L_mm": f"{dash['L_mm']:.2f}",
            "a_node": _node(dash, "a"), "b_node": _node(dash, "b")}
def lift_to_face(points_uv: np.ndarray, sign: np.ndarray, xyz: np.ndarray, uv: np.ndarray, faces: np.ndarray,
                 thickness: float) -> np.ndarray:
    """Points of Ω carried onto a face of the mattress: Ŝ offset by ``sign · thickness / 2`` along its top normal.

    Parameters
    ----------
    points_uv : ndarray of shape (k, 2)
        Points on Ω (the length unit of ``uv``).
    sign : ndarray of shape (k,)
        +1 for a point on the top face, -1 on the bottom face (0: on Ŝ).
    xyz, uv, faces
        Ŝ, as in :func:`lift_to_surface`.
    thickness : float
        The mattress thickness (the length unit of ``xyz``).

    Returns
    -------
    ndarray of shape (k, 3)
        The top normal (+z of Ω, carried by the triangles' orientation on Ω) is
        interpolated from Ŝ's area-weighted vertex normals and renormalized.

    Examples
    --------
    >>> uv = np.array([[0., 0.], [1., 0.], [0., 1.]])
    >>> xyz = np.column_stack([uv, np.zeros(3)])
    >>> lift_to_face(np.array([[0.2, 0.2], [0.2, 0.2]]), np.array([1, -1]), xyz, uv,
    ...              np.array([[0, 1, 2]]), 0.1).round(3).tolist()
    [[0.2, 0.2, 0.05], [0.2, 0.2, -0.05]]
    """
    from airmat.design.curvature import vertex_normals

    sign = np.asarray(sign, float).reshape(-1)
    base = lift_to_surface(points_uv, xyz, uv, faces)
    if len(sign) != len(base):
        raise ValueError(f"sign must have one value per point ({len(base)}), got {len(sign)}")
    e1, e2 = uv[faces[:, 1]] - uv[faces[:, 0]], uv[faces[:, 2]] - uv[faces[:, 0]]
    ccw = np.sum(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) >= 0      # winding of Ω's triangles seen from +z
    normals = vertex_normals(xyz, faces) * (1.0 if ccw else -1.0)
    n = lift_to_surface(points_uv, normals, uv, faces)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    return base + (0.5 * thickness * sign)[:, None] * n


def rhino_model(doc: dict, xyz: np.ndarray, uv: np.ndarray, faces: np.ndarray, *, shapes: dict | None = None,
                band: np.ndarray | None = None):
    """A ``rhino3dm.File3dm`` of a design (see the module docstring for its layers).

    Parameters
    ----------
    doc : dict
        The design document (:func:`airmat.design.export.design_json.design_document`, mm).
    xyz : ndarray of shape (n, 3)
        Ŝ's vertices (m).
    uv : ndarray of shape (n, 2)
        Their Ω coordinates (m).
    faces : ndarray of shape (m, 3)
    shapes : dict of str -> ndarray of shape (n, 3), optional
        Inflated shapes at Ŝ's vertices, aligned to Ŝ (m), e.g. ``{"median": ..., "lo95": ...}``;
        each becomes a mesh on Ŝ's triangles on layer ``inflated::KEY`` (only ``median`` visible).
    band : ndarray of shape (n,), optional
        The 95 % quantile of each Ŝ vertex's deviation over Monte-Carlo samples (m): Ŝ coloured by it
        on the hidden layer ``monte_carlo::p95``.

    Returns
    -------
    rhino3dm.File3dm
    """
    import rhino3dm as r

    model = r.File3dm()
    model.Settings.ModelUnitSystem = r.UnitSystem.Millimeters
    model.Settings.ModelAbsoluteTolerance = 0.01
    W, H = doc["mattress"]["width_mm"], doc["mattress"]["height_mm"]
    s_hat = _layer(model, "S_hat", (160, 160, 160))
    omega = _layer(model, "omega", (0, 0, 0))
    flat = {k: _layer(model, k, _COLOURS[k], omega) for k in FACE_FAMILIES}
    lifted = {k: _layer(model, k, _COLOURS[k], s_hat) for k in FACE_FAMILIES}
    ties_flat, ties_3d = _layer(model, "ties", (0, 0, 0), omega), _layer(model, "ties", (0, 0, 0), s_hat)
    model.Objects.AddMesh(_mesh(xyz * M_TO_MM, faces), _attributes(s_hat, "S_hat"))
    outline = [(0, 0, 0), (W, 0, 0), (W, H, 0), (0, H, 0), (0, 0, 0)]
    model.Objects.AddCurve(_polyline(outline),
                           _attributes(omega, "mattress", {
                               "width_mm": W, "height_mm": H, "thickness_mm": doc["mattress"]["thickness_mm"],
                               "design": doc.get("name", ""), "airmat_version": doc.get("airmat_version", ""),
                               "uncalibrated": doc.get("uncalibrated", False)}))
    dashes = doc["dashes"]
    polys = [np.asarray(d["polyline_mm"], float) for d in dashes]
    counts = np.array([len(p) for p in polys], int)
    if dashes:
        sign = np.repeat([1.0 if d["side"] == "top" else -1.0 for d in dashes], counts)
        up = lift_to_face(np.concatenate(polys) / M_TO_MM, sign, xyz, uv, faces,
                          doc["mattress"]["thickness_mm"] / M_TO_MM) * M_TO_MM
        up_parts = np.split(up, np.cumsum(counts)[:-1])
    for dash, poly, poly3 in zip(dashes, polys, up_parts if dashes else ()):
        key = f"{dash['side']}/{dash['family']}"
        text = string_text(dash)
        flat3 = np.column_stack([poly, np.zeros(len(poly))])
        model.Objects.AddCurve(_polyline(flat3), _attributes(flat[key], dash["id"], text))
        model.Objects.AddCurve(_polyline(poly3), _attributes(lifted[key], dash["id"], text))
        for end, p2, p3 in (("a", flat3[0], poly3[0]), ("b", flat3[-1], poly3[-1])):
            tie = {"id": dash["id"], "end": end, "node": text[f"{end}_node"]}
            model.Objects.AddPoint(r.Point3d(*p2), _attributes(ties_flat, f"{dash['id']} {end}", tie))
            model.Objects.AddPoint(r.Point3d(*p3), _attributes(ties_3d, f"{dash['id']} {end}", tie))
    if shapes:
        inflated = _layer(model, "inflated", (90, 90, 200))
        for key, shape in shapes.items():
            layer = _layer(model, key, (90, 90, 200) if key == "median" else (150, 150, 150), inflated,
                           visible=key == "median")
            model.Objects.AddMesh(_mesh(np.asarray(shape) * M_TO_MM, faces),
                                  _attributes(layer, f"inflated {key}", {"strings_at": key}))
    if band is not None:
        colours, lo, hi = band_colours(np.asarray(band, float) * M_TO_MM)
        layer = _layer(model, "p95", (150, 150, 150), _layer(model, "monte_carlo", (150, 150, 150)),
                       visible=False)
        text = {"quantity": "95 % quantile over the Monte-Carlo samples of the vertex's deviation from the "
                            "inflated shape (mm)",
                "colour_scale": "viridis, linear", "colour_low_mm": f"{lo:.2f}", "colour_high_mm": f"{hi:.2f}",
                "colour_low_rgb": ",".join(map(str, band_colours([0.0, 1.0])[0][0].tolist())),
                "colour_high_rgb": ",".join(map(str, band_colours([0.0, 1.0])[0][1].tolist()))}
        model.Objects.AddMesh(_band_mesh(xyz * M_TO_MM, faces, colours), _attributes(layer, "monte_carlo p95", text))
    return model


def rhino3dm_available() -> bool:
    """Whether rhino3dm is installed (it has no wheel for Python 3.10 on Apple silicon)."""
    import importlib.util

    return importlib.util.find_spec("rhino3dm") is not None


def write_3dm(path, doc: dict, xyz: np.ndarray, uv: np.ndarray, faces: np.ndarray, *,
              shapes: dict | None = None, band: np.ndarray | None = None) -> bool:
    """Write ``design.3dm`` (or ``inflated.3dm`` with ``shapes``) through :mod:`airmat.atomic`, byte-stable.

    Parameters are those of :func:`rhino_model`.

    Returns
    -------
    bool
        True when written; False, with a warning logged, where rhino3dm is not installed
        (no wheel for Python 3.10 on Apple silicon: Python 3.11 or later writes it).

    Raises
    ------
    airmat.errors.InputError
        rhino3dm could not write the file.
    """
    if not rhino3dm_available():
        logging.getLogger(__name__).warning(
            "%s not written: rhino3dm is not installed (it has no wheel for Python 3.10 on Apple silicon; "
            "Python 3.11 or later writes it)", Path(path).name)
        return False
    model = rhino_model(doc, xyz, uv, faces, shapes=shapes, band=band)
    data = stable_3dm_bytes(model, 8)
    if not data:
        raise InputError("rhino3dm could not write the .3dm file", path=path)
    atomic_write_bytes(path, data)
    return True
