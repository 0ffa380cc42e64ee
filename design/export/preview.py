"""``preview.png``: the pattern on Ω coloured by string length, and Ŝ coloured by σ.

Left: Ω (mm), top-face strings solid, bottom-face strings dashed, coloured
by the median string length (colour bar in mm), each outlined in black for
contrast, with black tie dots and its id beside it (the font shrinks with
the number of strings, legible at 150). Right: Ŝ in 3D (mm), each triangle
coloured by σ, the mean ratio of its edge lengths on Ŝ to those on Ω (1 = no
stretch), on a range symmetric about 1 that holds the triangles' σ and the
report's edge σ min and max (:func:`sigma_limits`). :func:`preview_figure` returns the
``matplotlib.figure.Figure``, :func:`write_preview` writes it; no pyplot
state (:mod:`airmat.figures`).
"""

from __future__ import annotations

import numpy as np

from airmat.figures import new_figure, save_png
from airmat.units import M_TO_MM

__all__ = ["preview_figure", "write_preview", "face_sigma", "sigma_limits", "id_font_size"]


def sigma_limits(sigma: np.ndarray, report: dict | None = None) -> tuple[float, float]:
    """Colour range of σ: symmetric about 1, holding every triangle's σ and the report's edge σ min/max.

    Examples
    --------
    >>> sigma_limits(np.array([0.99, 1.01]), {"sigma": {"min": 0.955, "max": 1.02}})
    (0.955, 1.045)
    """
    sig = (report or {}).get("sigma", {}) or {}
    values = [float(np.min(sigma)), float(np.max(sigma))] if len(sigma) else []
    values += [float(sig[k]) for k in ("min", "max") if k in sig]
    half = max([abs(v - 1.0) for v in values] + [0.005])
    return round(1.0 - half, 6), round(1.0 + half, 6)


def id_font_size(n_strings: int) -> float:
    """Font size (pt) of the string ids on the preview: 7 up to 40 strings, down to 4.5 at 150 and more."""
    return float(np.clip(7.0 - 2.5 * (n_strings - 40) / 110, 4.5, 7.0))


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
    from matplotlib import patheffects

    mappable = None
    outline = [patheffects.Stroke(linewidth=4.2, foreground="black"), patheffects.Normal()]
    for side, style in (("top", "solid"), ("bottom", (0, (4, 2)))):
        sel = [i for i, d in enumerate(dashes) if d["side"] == side]
        lc = LineCollection([np.asarray(dashes[i]["polyline_mm"]) for i in sel], linestyles=style,
                            linewidths=2.6, cmap="viridis", label=f"{side} face")
        lc.set_array(lengths[sel] if sel else np.zeros(0))
        lc.set_clim(*norm_lim)
        lc.set_path_effects(outline)
        ax.add_collection(lc)
        mappable = lc
    if dashes:
        ends = np.array([p for d in dashes for p in (d["polyline_mm"][0], d["polyline_mm"][-1])])
        ax.plot(ends[:, 0], ends[:, 1], "o", color="black", ms=2.5, zorder=3)
    size = id_font_size(len(dashes))
    for d in dashes:
        pts = np.asarray(d["polyline_mm"], float)
        mid, chord = pts[len(pts) // 2], pts[-1] - pts[0]
        angle = float(np.degrees(np.arctan2(chord[1], chord[0])))
        angle = angle - 180.0 if angle > 90.0 else angle + 180.0 if angle < -90.0 else angle
        ax.annotate(d["id"], mid, xytext=(-np.sin(np.radians(angle)) * 5, np.cos(np.radians(angle)) * 5),
                    textcoords="offset points", fontsize=size, rotation=angle, rotation_mode="anchor",
                    ha="center", va="bottom", color="black", gid=f"id-{d['id']}")
    if mappable is not None:
        fig.colorbar(mappable, ax=ax, shrink=0.8, label="string length l, median (mm)")
    ax.set_xlim(-0.03 * W, 1.03 * W)
    ax.set_ylim(-0.03 * H, 1.03 * H)
    ax.set_aspect("equal")
    ax.set_xlabel("u (mm)")
    ax.set_ylabel("v (mm)")
    ax.legend(loc="upper right", fontsize=7)
    ax.set_title(f"pattern on the mattress, top face seen from above\n{len(dashes)} strings "
                 f"(solid: top face, dashed: bottom face; ids as in cutting_list.csv)", fontsize=9)


def _surface_axes(fig, ax, xyz, uv, faces, report):
    from matplotlib import cm, colormaps, colors
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    sigma = face_sigma(xyz, uv, faces)
    p = np.asarray(xyz) * M_TO_MM
    lo, hi = sigma_limits(sigma, report)
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
    bar = fig.colorbar(sm, ax=ax, shrink=0.7, label="sigma: edge length on S^ / on mattress")
    sig = report.get("sigma", {}) or {}
    marks = {k: float(sig[k]) for k in ("min", "max") if k in sig}
    for k, v in marks.items():      # the report's edge σ min and max, marked on the scale
        bar.ax.axhline(v, color="black", lw=1.2)
        bar.ax.text(-0.15, v, f"{k} {v:.3f}", transform=bar.ax.get_yaxis_transform(), fontsize=7, va="center",
                    ha="right")
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
    fig = new_figure((16, 7.5))
    _pattern_axes(fig, fig.add_subplot(1, 2, 1), doc)
    _surface_axes(fig, fig.add_subplot(1, 2, 2, projection="3d"), np.asarray(xyz, float),
                  np.asarray(uv, float), faces, doc.get("report") or {})
    title = f"airmat design: {doc.get('name', '')}"
    if doc.get("uncalibrated"):
        title += "  (UNCALIBRATED: paper values)"
    fig.suptitle(title, fontsize=12)
    return fig


def write_preview(path, doc: dict, xyz, uv, faces, *, dpi: int = 100) -> None:
    """Write ``preview.png``, the :func:`preview_figure` of a design document and Ŝ (m)."""
    save_png(preview_figure(doc, xyz, uv, faces), path, dpi=dpi)
