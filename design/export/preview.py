"""``preview.png``: the pattern on Ω coloured by string length, and Ŝ coloured by σ.

Left: Ω (mm), top-face strings solid, bottom-face strings dotted, coloured
by the median string length (colour bar in mm). Right: Ŝ in 3D (mm), each
triangle coloured by σ, the mean ratio of its edge lengths on Ŝ to those on
Ω (1 = no stretch). :func:`preview_figure` returns the
``matplotlib.figure.Figure``, :func:`write_preview` writes it; no pyplot
state (:mod:`airmat.figures`).
"""

from __future__ import annotations

import numpy as np

from airmat.figures import new_figure, save_png
from airmat.units import M_TO_MM

__all__ = ["preview_figure", "write_preview", "face_sigma"]


def face_sigma(xyz: np.ndarray, uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Per-triangle σ (m,): mean over its three edges of |edge on Ŝ| / |edge on Ω|."""
    faces = np.asarray(faces)
    e3 = np.linalg.norm(xyz[np.roll(faces, -1, axis=1)] - xyz[faces], axis=2)
    e2 = np.linalg.norm(uv[np.roll(faces, -1, axis=1)] - uv[faces], axis=2)
    return np.mean(e3 / e2, axis=1)


def _pattern_axes(fig, ax, doc):
    from matplotlib.collections import LineCollection

    W, H = doc["mattress"]["width_mm"], doc["mattress"]["height_mm"]
    ax.plot([0, W, W, 0, 0], [0, 0, H, H, 0], color="black", lw=0.8)
    dashes = doc["dashes"]
    lengths = np.array([d["l_mm"]["median"] for d in dashes]) if dashes else np.zeros(0)
    norm_lim = (float(lengths.min()), float(lengths.max())) if len(lengths) else (0.0, 1.0)
    if norm_lim[0] == norm_lim[1]:
        norm_lim = (norm_lim[0] - 1.0, norm_lim[1] + 1.0)
    mappable = None
    for side, style in (("top", "solid"), ("bottom", "dotted")):
        sel = [i for i, d in enumerate(dashes) if d["side"] == side]
        lc = LineCollection([np.asarray(dashes[i]["polyline_mm"]) for i in sel], linestyles=style,
                            linewidths=2.0, cmap="viridis", label=f"{side} face")
        lc.set_array(lengths[sel] if sel else np.zeros(0))
        lc.set_clim(*norm_lim)
        ax.add_collection(lc)
        mappable = lc
    if mappable is not None:
        fig.colorbar(mappable, ax=ax, shrink=0.8, label="string length l, median (mm)")
    ax.set_xlim(-0.03 * W, 1.03 * W)
    ax.set_ylim(-0.03 * H, 1.03 * H)
    ax.set_aspect("equal")
    ax.set_xlabel("u (mm)")
    ax.set_ylabel("v (mm)")
    ax.legend(loc="upper right", fontsize=7)
    ax.set_title(f"pattern on the mattress, top face seen from above\n{len(dashes)} strings "
                 f"(solid: top face, dotted: bottom face)", fontsize=9)


def _surface_axes(fig, ax, xyz, uv, faces, report):
    from matplotlib import cm, colormaps, colors
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    sigma = face_sigma(xyz, uv, faces)
    p = np.asarray(xyz) * M_TO_MM
    lo, hi = min(float(sigma.min()), 0.98), max(float(sigma.max()), 1.02)
    norm = colors.Normalize(lo, hi)
    cmap = colormaps["coolwarm"]
    coll = Poly3DCollection(p[np.asarray(faces)], facecolors=cmap(norm(sigma)), edgecolors="none",
                            linewidths=0.0, antialiased=False)
    ax.add_collection3d(coll)
    span = p.max(axis=0) - p.min(axis=0)
    centre = 0.5 * (p.max(axis=0) + p.min(axis=0))
    r = 0.5 * float(span.max())
    ax.set_xlim(centre[0] - r, centre[0] + r)
    ax.set_ylim(centre[1] - r, centre[1] + r)
    ax.set_zlim(centre[2] - r, centre[2] + r)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    sm = cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.colorbar(sm, ax=ax, shrink=0.7, label="sigma: edge length on S^ / on mattress")
    sig = report.get("sigma", {})
    edges = (f"edge sigma min {sig['min']:.4f} / avg {sig['avg']:.4f} / max {sig['max']:.4f}"
             if {"min", "avg", "max"} <= set(sig) else "")
    verdict = "constructible" if report.get("constructible") else "NOT constructible (see design.json)"
    ax.set_title(f"approximated surface S^ coloured by sigma (triangle mean)\n{edges}; {verdict}", fontsize=9)


def preview_figure(doc: dict, xyz, uv, faces):
    """The preview of a design: its pattern on Ω and Ŝ coloured by σ.

    Parameters
    ----------
    doc : dict
        The design document (``design.json``, millimetres; see :mod:`design.export.design_json`).
    xyz : ndarray of shape (n, 3)
        Vertices of Ŝ (m).
    uv : ndarray of shape (n, 2)
        The same vertices on Ω (m).
    faces : ndarray of shape (m, 3)
        Triangles of Ŝ.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = new_figure((14, 6))
    _pattern_axes(fig, fig.add_subplot(1, 2, 1), doc)
    _surface_axes(fig, fig.add_subplot(1, 2, 2, projection="3d"), np.asarray(xyz, float),
                  np.asarray(uv, float), faces, doc.get("report", {}))
    title = f"airmat design: {doc.get('name', '')}"
    if doc.get("uncalibrated"):
        title += "  (UNCALIBRATED: paper values)"
    fig.suptitle(title, fontsize=12)
    return fig


def write_preview(path, doc: dict, xyz, uv, faces, *, dpi: int = 100) -> None:
    """Write ``preview.png``, the :func:`preview_figure` of a design document and Ŝ (m)."""
    save_png(preview_figure(doc, xyz, uv, faces), path, dpi=dpi)
