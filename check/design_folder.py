"""Read and check a design folder written by ``airmat design`` (for the inflation check).

The folder holds ``design.json`` (mattress, calibration, dashes with their
string lengths; mm) and ``approx_surface.ply`` (Ŝ with the Ω coordinates of
each vertex). Everything returned is in SI units (m, 1/m).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from airmat.errors import InputError
from airmat.units import MM
from inflation.strings import StringSet
from design.surface_io import read_approx_surface

__all__ = ["DesignFolder", "read_design_folder", "LENGTH_KEYS"]

LENGTH_KEYS = ("median", "lo95", "hi95")


@dataclass(frozen=True)
class DesignFolder:
    """What the inflation check needs from a design (SI).

    Attributes
    ----------
    path : Path
    width, height, thickness : float
        The mattress (m).
    delta : float
        Δ of the calibration's median (m): a string of length l is simulated at l + 2Δ.
    ids : tuple of str
    a, b : ndarray of shape (k, 2)
        String ends on Ω (m).
    top : ndarray of shape (k,), bool
        True for a string on the top face.
    lengths : dict of str -> ndarray of shape (k,)
        String length l (m) at its ``median``, ``lo95`` and ``hi95``.
    kappa : ndarray of shape (k,)
        Target (representative) signed curvature of each dash (1/m).
    polylines : tuple of ndarray of shape (p, 2)
        Each dash's path on Ω (m).
    approx_xyz, approx_uv, approx_faces : ndarray
        Ŝ: vertices (m), their Ω coordinates (m), triangles.
    doc : dict
        The raw design.json.
    """

    path: Path
    width: float
    height: float
    thickness: float
    delta: float
    ids: tuple
    a: np.ndarray
    b: np.ndarray
    top: np.ndarray
    lengths: dict
    kappa: np.ndarray
    polylines: tuple
    approx_xyz: np.ndarray
    approx_uv: np.ndarray
    approx_faces: np.ndarray
    doc: dict

    def strings(self, which: str = "median") -> StringSet:
        """The external strings at one end of their tolerance, rest length l* = l + 2Δ (m)."""
        return StringSet(self.a, self.b, self.top, self.lengths[which] + 2.0 * self.delta, self.ids)


def _get(doc, keys: str, path: Path):
    node = doc
    for key in keys.split("."):
        if not isinstance(node, dict) or key not in node:
            raise InputError(f"design.json has no field '{keys}': is this a folder written by "
                             f"'airmat design'?", path=path)
        node = node[key]
    return node


def _number(value, what: str, path: Path) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{what} is not a number: {value!r}", path=path) from None
    if not np.isfinite(x):
        raise InputError(f"{what} is not finite: {value!r}", path=path)
    return x


def _dashes(doc, path: Path, width: float, height: float):
    dashes = _get(doc, "dashes", path)
    if not isinstance(dashes, list):
        raise InputError("design.json field 'dashes' must be a list", path=path)
    rows = []
    for k, dash in enumerate(dashes):
        did = str(dash.get("id", f"#{k}")) if isinstance(dash, dict) else f"#{k}"
        try:
            a = np.asarray(dash["a_mm"], float) * MM
            b = np.asarray(dash["b_mm"], float) * MM
            side = dash["side"]
            l = [_number(dash["l_mm"][key], f"dash {did} l_mm.{key}", path) * MM for key in LENGTH_KEYS]
            kappa = _number(dash["kappa_per_m"], f"dash {did} kappa_per_m", path)
            poly = np.asarray(dash.get("polyline_mm", [dash["a_mm"], dash["b_mm"]]), float) * MM
        except (KeyError, TypeError) as err:
            raise InputError(f"dash {did} lacks field {err}", path=path) from None
        if a.shape != (2,) or b.shape != (2,) or side not in ("top", "bottom"):
            raise InputError(f"dash {did}: a_mm/b_mm must be [u, v] and side top or bottom", path=path)
        ends = np.stack([a, b])
        if np.any(ends < -1e-9) or np.any(ends[:, 0] > width + 1e-9) or np.any(ends[:, 1] > height + 1e-9):
            raise InputError(f"string {did} has an end outside the {width / MM:.0f} x {height / MM:.0f} mm "
                             f"mattress: a = {a / MM} mm, b = {b / MM} mm", path=path)
        if not (0.0 <= l[1] <= l[0] <= l[2]):
            raise InputError(f"dash {did}: l_mm must satisfy 0 <= lo95 <= median <= hi95", path=path)
        rows.append((did, a, b, side == "top", l, kappa, poly))
    return rows


def read_design_folder(folder) -> DesignFolder:
    """Read ``design.json`` and ``approx_surface.ply`` of a design folder.

    Raises
    ------
    airmat.errors.InputError
        A missing folder or file, a missing field (named), a string outside the
        mattress (its id named), or inconsistent lengths.
    """
    folder = Path(folder)
    path = folder / "design.json"
    if not folder.is_dir():
        raise InputError("design folder not found (give the --out folder of 'airmat design')", path=folder)
    if not path.is_file():
        raise InputError("no design.json here: give the --out folder of 'airmat design'", path=folder)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        raise InputError(f"cannot read design.json: {err}", path=path) from None
    width = _number(_get(doc, "mattress.width_mm", path), "mattress.width_mm", path) * MM
    height = _number(_get(doc, "mattress.height_mm", path), "mattress.height_mm", path) * MM
    thickness = _number(_get(doc, "mattress.thickness_mm", path), "mattress.thickness_mm", path) * MM
    delta = _number(_get(doc, "calibration.delta_mm.median", path), "calibration.delta_mm.median", path) * MM
    if min(width, height, thickness) <= 0 or delta < 0:
        raise InputError("mattress sizes must be > 0 and calibration delta >= 0", path=path)
    rows = _dashes(doc, path, width, height)
    xyz, uv, faces = read_approx_surface(folder / "approx_surface.ply")
    k = len(rows)
    col = lambda i: [r[i] for r in rows]  # noqa: E731
    lengths = np.array(col(4), float).reshape(k, 3)
    return DesignFolder(
        path=folder, width=width, height=height, thickness=thickness, delta=delta,
        ids=tuple(col(0)), a=np.array(col(1), float).reshape(k, 2), b=np.array(col(2), float).reshape(k, 2),
        top=np.array(col(3), bool), lengths={key: lengths[:, i] for i, key in enumerate(LENGTH_KEYS)},
        kappa=np.array(col(5), float), polylines=tuple(col(6)),
        approx_xyz=xyz, approx_uv=uv, approx_faces=faces, doc=doc)
