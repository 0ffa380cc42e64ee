"""``preview.png``: the pattern on Ω coloured by string length, and Ŝ coloured by σ.

Left, over most of the width and at Ω's aspect: Ω (mm), top-face strings
solid, bottom-face strings dashed, coloured by the median string length
(colour bar in mm), each outlined in black for contrast, with black tie dots
and its id beside it, along its chord. Ids are placed where they fit: each
takes the first spot along its string where it overlaps no other id
(:func:`place_labels`, greedy, the first dash of each line first), and the
title says how many are shown (all are in ``cutting_list.csv``); the legend
sits below the panel. Right: Ŝ in 3D (mm), each triangle
coloured by σ, the mean ratio of its edge lengths on Ŝ to those on Ω (1 = no
stretch), on a range symmetric about 1 that holds the triangles' σ and the
report's edge σ min and max (:func:`sigma_limits`). :func:`preview_figure` returns the
``matplotlib.figure.Figure``, :func:`write_preview` writes it; no pyplot
state (:mod:`airmat.figures`).
"""

from __future__ import annotations

import numpy as np

from airmat import palette
from airmat.figures import new_figure, save_png
from airmat.units import M_TO_MM

__all__ = ["preview_figure", "write_preview", "face_sigma", "sigma_limits", "id_font_size", "place_labels"]


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
    """Font size (pt) of the string ids on the preview: 8 up to 40 strings, down to 6.5 at 150 and more.

    Crowded ids are dropped rather than shrunk (:func:`non_overlapping`), so the size stays readable.
    """
    return float(np.clip(8.0 - 1.5 * (n_strings - 40) / 110, 6.5, 8.0))


def place_labels(candidates: np.ndarray, *, pad: float = 0.0) -> np.ndarray:
    """Greedy label placement: each label, in the given order of priority, takes its first candidate box
    that overlaps no box already taken, or none.

    Parameters
    ----------
    candidates : ndarray of shape (n, k, 4)
        For each of n labels, k candidate axis-aligned boxes ``(x0, y0, x1, y1)`` in one unit (the
        preview: display pixels), best first; NaN boxes are never taken.
    pad : float
        Extra gap required between two taken boxes, in the boxes' unit.

    Returns
    -------
    ndarray of int, shape (n,)
        The candidate taken by each label, -1 for a label left out.

    Examples
    --------
    >>> place_labels(np.array([[[0, 0, 2, 1], [0, 5, 2, 6]], [[1, 0, 3, 1], [9, 9, 9.5, 9.5]],
    ...                        [[1, 0.5, 3, 1.5], [9, 9, 10, 10]]]))
    array([ 0,  1, -1])
    """
    c = np.asarray(candidates, float)
    lo, hi = c[..., :2] - pad / 2, c[..., 2:] + pad / 2
    taken_lo, taken_hi = np.empty((0, 2)), np.empty((0, 2))
    choice = np.full(len(c), -1)
    for i in range(len(c)):     # greedy: each label's choice depends on the earlier ones
        clash = np.any(np.all((lo[i][:, None] < taken_hi[None]) & (taken_lo[None] < hi[i][:, None]), axis=2),
                       axis=1) | np.any(np.isnan(c[i]), axis=1)
        free = np.flatnonzero(~clash)
        if len(free):
            choice[i] = free[0]
            taken_lo, taken_hi = np.vstack([taken_lo, lo[i, free[0]]]), np.vstack([taken_hi, hi[i, free[0]]])
    return choice


def face_sigma(xyz: np.ndarray, uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Per-triangle σ (m,): mean over its three edges of |edge on Ŝ| / |edge on Ω|."""
    faces = np.asarray(faces)
    e3 = np.linalg.norm(xyz[np.roll(faces, -1, axis=1)] - xyz[faces], axis=2)
    e2 = np.linalg.norm(uv[np.roll(faces, -1, axis=1)] - uv[faces], axis=2)
    return np.mean(e3 / e2, axis=1)


def _draw_strings(ax, dashes):
    """The dashes as two LineCollections (top solid, bottom dashed) coloured by median length; the last one."""
    from matplotlib import patheffects
    from matplotlib.collections import LineCollection

    lengths = np.array([d["l_mm"]["median"] for d in dashes]) if dashes else np.zeros(0)
    lim = (float(lengths.min()), float(lengths.max())) if len(lengths) else (0.0, 1.0)
    if lim[0] == lim[1]:
        lim = (lim[0] - 1.0, lim[1] + 1.0)
    outline = [patheffects.Stroke(linewidth=4.2, foreground="black"), patheffects.Normal()]
    mappable = None
    for side, style in (("top", "solid"), ("bottom", (0, (4, 2)))):
        sel = [i for i, d in enumerate(dashes) if d["side"] == side]
        lc = LineCollection([np.asarray(dashes[i]["polyline_mm"]) for i in sel], linestyles=style,
                            linewidths=2.6, cmap="viridis", label=f"{side} face")
        lc.set_array(lengths[sel] if sel else np.zeros(0))
        lc.set_clim(*lim)
        lc.set_path_effects(outline)
        ax.add_collection(lc)
        mappable = lc
    if dashes:
        ends = np.array([p for d in dashes for p in (d["polyline_mm"][0], d["polyline_mm"][-1])])
        ax.plot(ends[:, 0], ends[:, 1], "o", color="black", ms=2.5, zorder=3)
    return mappable


ALONG = (0.5, 0.35, 0.65, 0.2, 0.8)     # where along a dash its id may sit, in order of preference


def _draw_ids(fig, ax, dashes):
    """Each string's id beside it, along its chord, at the first place in :data:`ALONG` where it overlaps no
    other id and stays inside Ω's panel (the first dash of each line first), else not at all.
    Returns the number of ids drawn."""
    from matplotlib import patheffects

    size = id_font_size(len(dashes))
    halo = [patheffects.withStroke(linewidth=2.0, foreground="white")]
    order = sorted(range(len(dashes)), key=lambda i: (str(dashes[i]["id"]).rsplit("-", 1)[-1], i))
    texts, spots = [], []
    for i in order:
        d = dashes[i]
        pts = np.asarray(d["polyline_mm"], float)
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
        at = np.column_stack([np.interp(np.asarray(ALONG) * arc[-1], arc, pts[:, k]) for k in (0, 1)])
        chord = pts[-1] - pts[0]
        angle = float(np.degrees(np.arctan2(chord[1], chord[0])))
        angle = angle - 180.0 if angle > 90.0 else angle + 180.0 if angle < -90.0 else angle
        texts.append(ax.annotate(d["id"], at[0], xytext=(-np.sin(np.radians(angle)) * 4,
                                                         np.cos(np.radians(angle)) * 4),
                                 textcoords="offset points", fontsize=size, rotation=angle,
                                 rotation_mode="anchor", ha="center", va="bottom", color="black",
                                 path_effects=halo, zorder=4, gid=f"id-{d['id']}"))
        spots.append(at)
    if not texts:
        return 0
    ax.apply_aspect()
    renderer = fig.canvas.get_renderer()
    box = np.array([t.get_window_extent(renderer).extents for t in texts])          # (n, 4) at ALONG[0]
    px = ax.transData.transform(np.concatenate(spots)).reshape(len(texts), len(ALONG), 2)
    shift = np.tile(px - px[:, :1], 2)                                               # (n, k, 4)
    cand = box[:, None, :] + shift
    frame = ax.get_window_extent(renderer).extents
    inside = np.all(cand[..., :2] >= frame[:2], axis=2) & np.all(cand[..., 2:] <= frame[2:], axis=2)
    cand[~inside] = np.nan
    choice = place_labels(cand, pad=1.0)
    for t, c, at in zip(texts, choice, spots):
        if c < 0:
            t.remove()
        else:
            t.xy = tuple(at[c])
    return int(np.sum(choice >= 0))


def _pattern_axes(fig, ax, cax, doc):
    from matplotlib.lines import Line2D

    W, H = doc["mattress"]["width_mm"], doc["mattress"]["height_mm"]
    ax.plot([0, W, W, 0, 0], [0, 0, H, H, 0], color="black", lw=0.8)
    dashes = doc["dashes"]
    mappable = _draw_strings(ax, dashes)
    ax.set_xlim(-0.02 * W, 1.02 * W)
    ax.set_ylim(-0.02 * H, 1.02 * H)
    ax.set_aspect("equal")
    ax.set_anchor("W")
    ax.set_xlabel("u (mm)")
    ax.set_ylabel("v (mm)")
    if mappable is not None:
        fig.colorbar(mappable, cax=cax, label="string length l, median (mm)")
    n_ids = _draw_ids(fig, ax, dashes)
    handles = [Line2D([], [], color="black", lw=2.6, ls=ls, label=f"{side} face")
               for side, ls in (("top", "-"), ("bottom", (0, (4, 2))))]
    handles.append(Line2D([], [], color="black", ls="none", marker="o", ms=4, label="tie point"))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(0.0, -0.06), ncol=3, fontsize=9,
              frameon=False)
    shown = (f"ids of all {len(dashes)} strings" if n_ids == len(dashes)
             else f"ids of {n_ids} of {len(dashes)} strings (the rest too crowded to print)")
    ax.set_title(f"pattern on the mattress, top face seen from above: {len(dashes)} strings "
                 f"(solid: top face, dashed: bottom face)\n{shown}; all ids and lengths in cutting_list.csv",
                 fontsize=11)


def _surface_axes(fig, ax, cax, xyz, uv, faces, report):
    from matplotlib import cm, colormaps, colors
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    sigma = face_sigma(xyz, uv, faces)
    p = np.asarray(xyz) * M_TO_MM
    lo, hi = sigma_limits(sigma, report)
    norm = colors.Normalize(lo, hi)
    cmap = colormaps[palette.SIGMA.matplotlib]
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
    bar = fig.colorbar(sm, cax=cax, label="sigma: edge length on S^ / on mattress")
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
    ax.set_title(f"approximated surface S^, coloured by sigma (triangle mean)\n{edges}\n{verdict}", fontsize=10)


def preview_figure(doc: dict, xyz, uv, faces):
    """The preview of a design: its pattern on Ω and Ŝ coloured by σ.

    Parameters
    ----------
    doc : dict
        The design document (``design.json``, millimetres; see :mod:`airmat.design.export.design_json`).
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
    W, H = doc["mattress"]["width_mm"], doc["mattress"]["height_mm"]
    width, pw = 20.0, 12.0                                   # inches: figure, pattern panel
    ph = float(np.clip(pw * H / W, 4.0, 12.0))               # Ω's aspect, within a printable height
    top, bottom = 1.3, 1.0                                   # inches for titles; x label and legend
    height = ph + top + bottom
    fig = new_figure((width, height))
    y0, h = bottom / height, ph / height
    _pattern_axes(fig, fig.add_axes((0.045, y0, pw / width, h)),
                  fig.add_axes((0.045 + pw / width + 0.008, y0, 0.010, h)), doc)
    s3 = min(ph, 5.0) / height
    ax3 = fig.add_axes((0.715, y0 + 0.5 * (h - s3), 0.20, s3), projection="3d")
    cax3 = fig.add_axes((0.94, y0 + 0.5 * (h - 0.8 * s3), 0.010, 0.8 * s3))   # below the 3D panel's title
    _surface_axes(fig, ax3, cax3, np.asarray(xyz, float), np.asarray(uv, float), faces,
                  doc.get("report") or {})
    title = f"airmat design: {doc.get('name', '')}"
    if doc.get("uncalibrated"):
        title += "  (UNCALIBRATED: paper values)"
    fig.suptitle(title, fontsize=12)
    return fig


def write_preview(path, doc: dict, xyz, uv, faces, *, dpi: int = 100) -> None:
    """Write ``preview.png``, the :func:`preview_figure` of a design document and Ŝ (m)."""
    save_png(preview_figure(doc, xyz, uv, faces), path, dpi=dpi)
