"""Synthetic scans of cylindrical calibration specimens (paper §2.2, Figure 3).

A strip of the mattress (width ``width`` along the cylinder axis) bent to a
cylinder of curvature kappa, scanned from above: only the visible part of
its top face, at radius ``1/kappa``, appears (arcs down to about 40 degrees),
with what makes real scans hard:

- wrinkle grooves at the string ends: systematic dips of ``groove_depth``
  (several mm) along lines across the strip (parallel to the axis), spaced
  ``L`` along the arc;
- isotropic Gaussian scanner noise ``noise``;
- a floor plane under the specimen, with the specimen's shadow missing;
- clutter: ``outlier_fraction`` of the points, half uniform in the scene's
  box, half in a few clumps;
- holes (missing patches) and a mildly non-uniform density (incidence
  fall-off and a smooth random modulation);
- a random rigid pose, so nothing is axis-aligned.

kappa = 0 gives a flat strip lying on the floor (two parallel planes
``thickness`` apart). The thickness only places the floor: the visible
face is modelled, not the mattress body. Everything is in metres and 1/m,
and seeded: the same seed gives the same points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from airmat.constants import PAPER_D, PAPER_L
from airmat.errors import InputError

__all__ = ["SpecimenScan", "specimen_scan", "SPECIMEN", "FLOOR", "CLUTTER"]

#: point labels
SPECIMEN, FLOOR, CLUTTER = 0, 1, 2


@dataclass(frozen=True)
class SpecimenScan:
    """A synthetic specimen scan and its ground truth (SI units).

    Attributes
    ----------
    points : ndarray of shape (N, 3)
        Scan points (m), shuffled.
    labels : ndarray of shape (N,), int8
        :data:`SPECIMEN`, :data:`FLOOR` or :data:`CLUTTER` per point.
    kappa : float
        True curvature of the scanned face (1/m).
    radius : float
        ``1/kappa`` (m); ``inf`` for a flat strip.
    axis : ndarray of shape (3,)
        Unit cylinder axis (for a flat strip: the direction across the strip).
    center : ndarray of shape (3,)
        A point on the axis (flat strip: the middle of the visible face) (m).
    normal : ndarray of shape (3,)
        Unit normal of the floor, pointing up toward the scanner.
    arc_deg : float
        Angle of the visible arc (0 for a flat strip).
    groove_s : ndarray of shape (G,)
        Arc-length positions of the grooves relative to the middle of the
        visible window (m).
    rotation : ndarray of shape (3, 3)
        Rotation applied to the specimen frame (axis = y, apex up = z).
    translation : ndarray of shape (3,)
        Translation applied after the rotation (m).
    noise : float
        Standard deviation of the Gaussian noise (m).
    """

    points: np.ndarray
    labels: np.ndarray
    kappa: float
    radius: float
    axis: np.ndarray
    center: np.ndarray
    normal: np.ndarray
    arc_deg: float
    groove_s: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray
    noise: float


def specimen_scan(kappa: float, *, L: float = PAPER_L, n_strings: int = 3, width: float = 0.4,
                  thickness: float = PAPER_D, n_points: int = 100_000, noise: float = 0.0005,
                  floor: bool = True, outlier_fraction: float = 0.05, holes: bool = True,
                  groove_depth: float = 0.004, max_arc_deg: float = 150.0,
                  density_variation: float = 0.5, seed=0, arc_deg: float | None = None,
                  groove_width: float = 0.025, floor_fraction: float = 0.3,
                  floor_margin: float = 0.3, n_holes: int = 3, hole_radius: float = 0.04,
                  pose: bool = True) -> SpecimenScan:
    """Synthesize a scan of a strip bent to curvature ``kappa``.

    Parameters
    ----------
    kappa : float
        Curvature of the scanned face (1/m), >= 0; 0 is a flat strip.
    L : float
        Geodesic spacing of the string ends (m): the grooves are ``L`` apart.
    n_strings : int
        Strings in series along the strip; the strip is ``(n_strings + 0.5) L`` long.
    width : float
        Strip width along the cylinder axis (m).
    thickness : float
        Mattress thickness (m): the floor lies this far below the lowest
        visible point.
    n_points : int
        Total points (specimen + floor + clutter).
    noise : float
        Standard deviation of the isotropic Gaussian noise (m).
    floor : bool
        Add a floor plane (``floor_fraction`` of the points).
    outlier_fraction : float
        Fraction of clutter points.
    holes : bool
        Cut ``n_holes`` round patches of radius up to ``hole_radius`` (m).
    groove_depth : float
        Depth of the string-end grooves (m); 0 for none.
    max_arc_deg : float
        Largest visible arc; a strip bent further is seen only over this angle.
    density_variation : float
        In [0, 1): depth of the smooth random density modulation.
    seed : int or numpy Generator
        Seed of every random step.
    arc_deg : float, optional
        Visible arc (degrees), overriding the strip length (the strip is
        taken long enough).
    groove_width : float
        Full width at half depth of a groove (m).
    floor_fraction, floor_margin : float
        Share of the points on the floor, and how far it extends around the
        specimen's footprint (m).
    n_holes, hole_radius : int, float
        Number and largest radius (m) of the holes.
    pose : bool
        Apply a random rigid motion (False: specimen frame, axis = y, up = z).

    Returns
    -------
    SpecimenScan

    Examples
    --------
    >>> s = specimen_scan(5.0, n_points=20_000, arc_deg=60, seed=1)
    >>> s.points.shape, round(s.radius, 3)
    ((20000, 3), 0.2)
    """
    _check(kappa, n_points=n_points, noise=noise, outlier_fraction=outlier_fraction,
           floor_fraction=floor_fraction, density_variation=density_variation, arc_deg=arc_deg)
    rng = np.random.default_rng(seed)
    kappa = float(kappa)
    strip = (n_strings + 0.5) * L
    if kappa > 0:
        arc = np.radians(arc_deg) if arc_deg is not None else min(strip * kappa, np.radians(max_arc_deg))
        window = arc / kappa
    else:
        arc, window = 0.0, strip
    tilt = rng.uniform(-1, 1) * min(np.radians(10), max(np.pi - arc, 0) / 2) if kappa > 0 else 0.0
    shift = rng.uniform(-0.5, 0.5) * max(strip - window, 0.0)
    period_offset = (n_strings % 2) * L / 2
    k = np.arange(np.floor((shift - window) / L) - 1, np.ceil((shift + window) / L) + 2)
    grooves = k * L + period_offset - shift  # relative to the window middle
    grooves = grooves[np.abs(grooves) < window / 2 + groove_width]
    n_floor = int(round(floor_fraction * n_points)) if floor else 0
    n_out = int(round(outlier_fraction * n_points))
    n_spec = n_points - n_floor - n_out
    spec = _specimen(rng, n_spec, kappa=kappa, window=window, width=width, tilt=tilt, grooves=grooves,
                     depth=groove_depth, groove_width=groove_width, density_variation=density_variation,
                     holes=holes, n_holes=n_holes, hole_radius=hole_radius)
    z_floor = spec[:, 2].min() - thickness
    parts = [spec]
    if n_floor:
        parts.append(_floor(rng, n_floor, spec, width, z_floor, floor_margin))
    local = np.concatenate(parts)
    local = local + rng.normal(0.0, noise, local.shape)
    local = np.concatenate([local, _clutter(rng, n_out, local, z_floor)])
    labels = np.repeat(np.array([SPECIMEN, FLOOR, CLUTTER], np.int8), [n_spec, n_floor, n_out])
    rot = Rotation.random(rng=rng).as_matrix() if pose else np.eye(3)
    trans = rng.uniform(-1.0, 1.0, 3) if pose else np.zeros(3)
    order = rng.permutation(len(local))
    return SpecimenScan(points=local[order] @ rot.T + trans, labels=labels[order], kappa=kappa,
                        radius=1.0 / kappa if kappa > 0 else np.inf, axis=rot[:, 1].copy(),
                        center=trans.copy(), normal=rot[:, 2].copy(), arc_deg=float(np.degrees(arc)),
                        groove_s=grooves, rotation=rot, translation=trans, noise=float(noise))


def _check(kappa, *, n_points, noise, outlier_fraction, floor_fraction, density_variation, arc_deg):
    if not (np.isfinite(kappa) and kappa >= 0):
        raise InputError(f"kappa must be finite and >= 0 1/m, got {kappa!r}", kappa=kappa)
    if n_points < 100:
        raise InputError(f"n_points must be >= 100, got {n_points}")
    if not noise >= 0:
        raise InputError(f"noise must be >= 0 m, got {noise!r}")
    if not (0 <= outlier_fraction < 0.5 and 0 <= floor_fraction < 0.9
            and outlier_fraction + floor_fraction < 0.95):
        raise InputError("need 0 <= outlier_fraction < 0.5, 0 <= floor_fraction < 0.9 and room "
                         "for the specimen", outlier_fraction=outlier_fraction, floor_fraction=floor_fraction)
    if not 0 <= density_variation < 1:
        raise InputError(f"density_variation must be in [0, 1), got {density_variation!r}")
    if arc_deg is not None and not 0 < arc_deg <= 180:
        raise InputError(f"arc_deg must be in (0, 180], got {arc_deg!r}")


def _specimen(rng, n, *, kappa, window, width, tilt, grooves, depth, groove_width,
              density_variation, holes, n_holes, hole_radius):
    """(n, 3) points of the visible face in the specimen frame (noise-free)."""
    lam = rng.uniform(0.15, 0.4, 2)
    phase = rng.uniform(0, 2 * np.pi, 2)
    if holes and n_holes > 0:
        cap = 0.25 * min(window, width)
        hole_c = rng.uniform([-window / 2, -width / 2], [window / 2, width / 2], (n_holes, 2))
        hole_r = rng.uniform(0.5, 1.0, n_holes) * min(hole_radius, cap)
    else:
        hole_c, hole_r = np.empty((0, 2)), np.empty(0)
    accepted, total = [], 0
    while total < n:  # rejection sampling in batches (a few rounds)
        m = int(2.5 * (n - total)) + 64
        s = rng.uniform(-window / 2, window / 2, m)
        y = rng.uniform(-width / 2, width / 2, m)
        phi = kappa * s + tilt
        modulation = 0.5 + 0.5 * np.sin(2 * np.pi * s / lam[0] + phase[0]) * np.cos(2 * np.pi * y / lam[1] + phase[1])
        accept = (1.0 - density_variation * modulation) * np.maximum(np.cos(phi), 0.25)
        keep = rng.random(m) < accept
        d2 = (s[:, None] - hole_c[:, 0]) ** 2 + (y[:, None] - hole_c[:, 1]) ** 2
        keep &= ~np.any(d2 < hole_r ** 2, axis=1)
        accepted.append(np.stack([s[keep], y[keep]], axis=1))
        total += int(keep.sum())
    sy = np.concatenate(accepted)[:n]
    s, y = sy[:, 0], sy[:, 1]
    g = groove_width / (2 * np.sqrt(2 * np.log(2)))
    dip = depth * np.exp(-0.5 * ((s[:, None] - grooves) / g) ** 2).sum(axis=1) if len(grooves) else 0 * s
    if kappa > 0:
        r = 1.0 / kappa - dip
        phi = kappa * s + tilt
        return np.stack([r * np.sin(phi), y, r * np.cos(phi)], axis=1)
    return np.stack([s, y, -dip], axis=1)


def _floor(rng, n, spec, width, z_floor, margin):
    """(n, 3) floor points around the specimen's footprint, its shadow left out."""
    x0, x1 = spec[:, 0].min(), spec[:, 0].max()
    lo = np.array([x0 - margin, -width / 2 - margin])
    hi = np.array([x1 + margin, width / 2 + margin])
    shadow = (x1 - x0) * width / np.prod(hi - lo)
    out, total = [], 0
    while total < n:
        m = int(1.3 * (n - total) / max(1 - shadow, 0.05)) + 64
        xy = rng.uniform(lo, hi, (m, 2))
        keep = ~((xy[:, 0] > x0) & (xy[:, 0] < x1) & (np.abs(xy[:, 1]) < width / 2))
        out.append(xy[keep])
        total += int(keep.sum())
    xy = np.concatenate(out)[:n]
    return np.column_stack([xy, np.full(n, z_floor)])


def _clutter(rng, n, scene, z_floor):
    """(n, 3) outliers: half uniform in the scene's box, half in three clumps."""
    lo, hi = scene.min(axis=0), scene.max(axis=0)
    lo[2], hi[2] = z_floor, hi[2] + 0.1 * np.ptp(scene[:, 2]) + 0.05
    n_box = n // 2
    box = rng.uniform(lo, hi, (n_box, 3))
    centers = rng.uniform(lo, hi, (3, 3))
    which = rng.integers(0, 3, n - n_box)
    size = 0.02 + 0.03 * rng.random(3)
    clumps = centers[which] + rng.normal(size=(n - n_box, 3)) * size[which, None]
    return np.concatenate([box, clumps])
