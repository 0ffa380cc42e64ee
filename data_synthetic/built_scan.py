"""A synthetic scan of a surface given as a triangle mesh: what a scanner above it records.

:func:`scan_surface` samples the triangles (the upper face of a built mattress,
:mod:`airmat.asbuilt.true_world`) the way :mod:`airmat.synthetic.specimen_scan`
scans a specimen, with what makes real scans hard:

- points spread by area, thinned where the surface turns away from the scanner
  (density ∝ max(n_z, 0.25), the incidence fall-off), with isotropic Gaussian
  noise ``noise``;
- partial coverage: seeded round holes (occlusions, dark or shiny patches) cut
  out of the surface until exactly ``1 − coverage`` of its area is missing;
- a floor plane at the surface's lowest point (or ``floor_z``), around its
  footprint and not under it (its shadow);
- clutter: a few boxes standing on the floor beside the surface (their tops and
  sides) and stray points in the scene's box;
- a rigid motion (random unless given) and the unit of the file (mm or m).

The scanner looks down along −z of the input frame; self-occlusion of the
given surface is not modelled (give only the faces it sees). Input in metres;
every random step takes ``seed``: the same seed gives the same points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import Delaunay
from scipy.spatial.transform import Rotation

from airmat.errors import InputError

__all__ = ["SurfaceScan", "scan_surface", "SURFACE", "FLOOR", "CLUTTER", "UNITS"]

#: point labels
SURFACE, FLOOR, CLUTTER = 0, 1, 2

#: scan unit -> metres per unit
UNITS = {"mm": 1e-3, "m": 1.0}


@dataclass(frozen=True)
class SurfaceScan:
    """A synthetic scan and its ground truth.

    Attributes
    ----------
    points : ndarray of shape (N, 3)
        Scan points in ``units``, shuffled.
    labels : ndarray of shape (N,), int8
        :data:`SURFACE`, :data:`FLOOR` or :data:`CLUTTER` per point.
    rotation : ndarray of shape (3, 3)
        R of the motion applied: scan (m) = R x + t, x in the input frame (m).
    translation : ndarray of shape (3,)
        t (m).
    units : {"mm", "m"}
        Unit of ``points``.
    coverage : float
        Share of the surface's area outside the holes (the requested one, to the
        sampling's resolution: ``coverage_points`` of the pool).
    hole_centers : ndarray of shape (h, 3)
        Centres of the holes in the input frame (m); a point of the surface within
        ``hole_radii`` of one (3D distance) is missing.
    hole_radii : ndarray of shape (h,)
        (m).
    floor_z : float or None
        Height of the floor plane in the input frame (m); None without a floor.
    noise : float
        Standard deviation of the noise (m).
    """

    points: np.ndarray
    labels: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray
    units: str
    coverage: float
    hole_centers: np.ndarray
    hole_radii: np.ndarray
    floor_z: float | None
    noise: float

    def to_input_frame(self, points=None) -> np.ndarray:
        """Scan points (in ``units``; default this scan's) back in the input frame (m): Rᵀ(p·s − t)."""
        p = self.points if points is None else np.asarray(points, float)
        return (p * UNITS[self.units] - self.translation) @ self.rotation

    def inverse(self) -> tuple:
        """(R_back, t_back): x = R_back p + t_back maps a scan point p (in ``units``) to the input frame
        (in ``units`` too): R_back = Rᵀ, t_back = −Rᵀ t expressed in ``units``."""
        back = self.rotation.T
        return back, -back @ self.translation / UNITS[self.units]


def scan_surface(vertices, faces, *, n_points: int = 200_000, noise: float = 0.0005, coverage: float = 0.85,
                 floor: bool = True, clutter: bool = True, rotation=None, translation=None, units: str = "mm",
                 seed=0, floor_z: float | None = None, floor_fraction: float = 0.25,
                 clutter_fraction: float = 0.04, floor_margin: float = 0.4, hole_radius: float | None = None,
                 pose: bool = True) -> SurfaceScan:
    """Scan the triangles ``faces`` of ``vertices`` from above, with holes, floor, clutter and a pose.

    Parameters
    ----------
    vertices : ndarray of shape (n, 3)
        (m); +z points toward the scanner.
    faces : ndarray of shape (t, 3)
        Triangles (vertex indices), oriented with their normals toward the scanner (the
        incidence fall-off uses n_z).
    n_points : int
        Total points (surface + floor + clutter), >= 100.
    noise : float
        Standard deviation of the isotropic Gaussian noise (m), >= 0.
    coverage : float
        In (0, 1]: share of the surface's area that is scanned; the rest is in holes.
    floor, clutter : bool
        Add a floor plane (``floor_fraction`` of the points) and clutter (``clutter_fraction``).
    rotation : ndarray of shape (3, 3), optional
        R of the pose scan = R x + t; default a random rotation (``pose``), else the identity.
    translation : ndarray of shape (3,), optional
        t (m); default uniform in [−2, 2] m per axis (``pose``), else zero.
    units : {"mm", "m"}
        Unit of the returned points.
    seed : int, sequence of int or numpy Generator
        Seed of every random step.
    floor_z : float, optional
        Height of the floor (m); default the lowest vertex.
    floor_fraction, clutter_fraction : float
        Shares of the points on the floor and in the clutter.
    floor_margin : float
        How far the floor extends around the surface's footprint (m).
    hole_radius : float, optional
        Largest hole radius (m); default 12 % of the surface's diagonal.
    pose : bool
        Draw a random pose when ``rotation``/``translation`` are not given.

    Returns
    -------
    SurfaceScan

    Examples
    --------
    >>> v = np.array([[0., 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    >>> s = scan_surface(v, np.array([[0, 1, 2], [0, 2, 3]]), n_points=5000, coverage=0.8, seed=1)
    >>> s.points.shape, s.units, round(s.coverage, 2)
    ((5000, 3), 'mm', 0.8)
    """
    v, f = _check(vertices, faces, n_points=n_points, noise=noise, coverage=coverage, units=units,
                  floor_fraction=floor_fraction, clutter_fraction=clutter_fraction)
    rng = np.random.default_rng(seed)
    n_floor = int(round(floor_fraction * n_points)) if floor else 0
    n_clutter = int(round(clutter_fraction * n_points)) if clutter else 0
    n_surf = n_points - n_floor - n_clutter
    tri = v[f]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = 0.5 * np.linalg.norm(normal, axis=1)
    nz = normal[:, 2] / np.maximum(2 * area, np.finfo(float).tiny)
    diag = float(np.linalg.norm(np.ptp(v[np.unique(f)], axis=0)))
    incidence = np.maximum(nz, 0.25)
    # an area-uniform pool: the holes are cut out of it by area, then the incidence thins it
    expected = coverage * float(np.sum(area * incidence) / area.sum())
    pool_size = int(np.ceil(1.2 * n_surf / expected)) + 256
    pool = _sample_triangles(rng, tri, area, pool_size)
    keep, centers, radii = _holes(rng, pool[0], coverage, 0.12 * diag if hole_radius is None else hole_radius)
    owner = pool[1][keep]
    accept = rng.random(owner.size) < incidence[owner]
    surf = pool[0][keep][accept]
    if len(surf) < n_surf:       # the pool's margin is generous; this only guards the count
        raise InputError(f"could not place {n_surf} points on the surface ({len(surf)} after holes and incidence)")
    surf = surf[rng.permutation(len(surf))[:n_surf]]
    z0 = float(v[:, 2].min()) if floor_z is None else float(floor_z)
    parts = [surf]
    if n_floor:
        parts.append(_floor(rng, n_floor, v[np.unique(f)], z0, floor_margin))
    if n_clutter:
        parts.append(_clutter(rng, n_clutter, v[np.unique(f)], z0, floor_margin))
    local = np.concatenate(parts)
    local = local + rng.normal(0.0, noise, local.shape)
    labels = np.repeat(np.array([SURFACE, FLOOR, CLUTTER], np.int8), [n_surf, n_floor, n_clutter])
    rot = _rotation(rng, rotation, pose)
    trans = (rng.uniform(-2.0, 2.0, 3) if pose else np.zeros(3)) if translation is None \
        else np.asarray(translation, float).reshape(3)
    order = rng.permutation(len(local))
    points = (local[order] @ rot.T + trans) / UNITS[units]
    return SurfaceScan(points=points, labels=labels[order], rotation=rot, translation=trans, units=units,
                       coverage=float(keep.mean()), hole_centers=centers, hole_radii=radii,
                       floor_z=z0 if n_floor else None, noise=float(noise))


def _check(vertices, faces, *, n_points, noise, coverage, units, floor_fraction, clutter_fraction):
    v = np.asarray(vertices, float)
    f = np.asarray(faces)
    if v.ndim != 2 or v.shape[1] != 3 or not np.all(np.isfinite(v)):
        raise InputError(f"vertices have shape {v.shape}, expected finite (n, 3)")
    if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0 or not np.issubdtype(f.dtype, np.integer) \
            or f.min() < 0 or f.max() >= len(v):
        raise InputError(f"faces have shape {f.shape}, expected (t, 3) indices into {len(v)} vertices")
    if not (isinstance(n_points, (int, np.integer)) and n_points >= 100):
        raise InputError(f"n_points must be an integer >= 100, got {n_points!r}")
    if not (np.isfinite(noise) and noise >= 0):
        raise InputError(f"noise must be >= 0 m, got {noise!r}", noise=noise)
    if not (0 < coverage <= 1):
        raise InputError(f"coverage must be in (0, 1], got {coverage!r}", coverage=coverage)
    if units not in UNITS:
        raise InputError(f"scan unit {units!r}: expected one of {', '.join(UNITS)}")
    if not (0 <= floor_fraction < 0.9 and 0 <= clutter_fraction < 0.5 and floor_fraction + clutter_fraction < 0.9):
        raise InputError("need 0 <= floor_fraction < 0.9, 0 <= clutter_fraction < 0.5 and room for the surface",
                         floor_fraction=floor_fraction, clutter_fraction=clutter_fraction)
    return v, f


def _rotation(rng, rotation, pose) -> np.ndarray:
    if rotation is None:
        return Rotation.random(rng=rng).as_matrix() if pose else np.eye(3)
    rot = np.asarray(rotation, float)
    if rot.shape != (3, 3) or not np.allclose(rot @ rot.T, np.eye(3), atol=1e-9) or np.linalg.det(rot) <= 0:
        raise InputError(f"rotation must be a proper rotation matrix of shape (3, 3), got shape {rot.shape}")
    return rot


def _sample_triangles(rng, tri, area, n) -> tuple:
    """n points uniform by area on the triangles (m) and the triangle of each."""
    owner = rng.choice(len(tri), size=n, p=area / area.sum())
    r1, r2 = rng.random(n), rng.random(n)
    flip = r1 + r2 > 1                          # fold the square onto the triangle
    r1, r2 = np.where(flip, 1 - r1, r1), np.where(flip, 1 - r2, r2)
    t = tri[owner]
    return t[:, 0] + r1[:, None] * (t[:, 1] - t[:, 0]) + r2[:, None] * (t[:, 2] - t[:, 0]), owner


def _holes(rng, pool, coverage, radius) -> tuple:
    """Round holes centred on the surface until 1 − coverage of the pool is inside one.

    Holes of radius in [0.4, 1] x ``radius`` are added one at a time (a handful: a loop
    over holes, vectorized over points); the last one's radius is set so that exactly
    the share asked for is missing.
    """
    keep = np.ones(len(pool), bool)
    target = int(round((1.0 - coverage) * len(pool)))
    centers, radii = [], []
    while len(pool) - keep.sum() < target:
        c = pool[rng.integers(len(pool))]
        dist = np.linalg.norm(pool - c, axis=1)
        r = rng.uniform(0.4, 1.0) * radius
        inside = keep & (dist < r)
        still = target - (len(pool) - keep.sum())
        if inside.sum() > still:                # the last hole: just large enough
            r = float(np.sort(dist[keep])[still - 1]) * (1 + 1e-12)
            inside = keep & (dist < r)
        if inside.any():
            keep &= ~inside
            centers.append(c)
            radii.append(r)
    return keep, np.array(centers).reshape(-1, 3), np.array(radii, float)


def _floor(rng, n, surface, z0, margin) -> np.ndarray:
    """(n, 3) floor points around the surface's footprint (its convex hull), none under it."""
    xy = surface[:, :2]
    lo, hi = xy.min(axis=0) - margin, xy.max(axis=0) + margin
    hull = Delaunay(xy)
    out, total = [], 0
    while total < n:                            # rejection in a few batches
        cand = rng.uniform(lo, hi, (int(2.0 * (n - total)) + 64, 2))
        cand = cand[hull.find_simplex(cand) < 0]
        out.append(cand)
        total += len(cand)
    return np.column_stack([np.concatenate(out)[:n], np.full(n, z0)])


def _clutter(rng, n, surface, z0, margin) -> np.ndarray:
    """(n, 3) clutter: three boxes on the floor beside the surface (top and sides), a fifth stray points."""
    lo, hi = surface.min(axis=0), surface.max(axis=0)
    n_stray = n // 5
    n_box = n - n_stray
    size = rng.uniform([0.1, 0.1, 0.05], [0.35, 0.35, 0.5], (3, 3))
    side = rng.integers(0, 4, 3)                # which side of the footprint each box stands on
    along = rng.random(3)
    cx = np.select([side == 0, side == 1], [lo[0] - margin / 2, hi[0] + margin / 2], lo[0] + along * (hi[0] - lo[0]))
    cy = np.select([side == 2, side == 3], [lo[1] - margin / 2, hi[1] + margin / 2], lo[1] + along * (hi[1] - lo[1]))
    which = rng.integers(0, 3, n_box)
    u = rng.uniform(-0.5, 0.5, (n_box, 3))
    face = rng.integers(0, 5, n_box)            # 0: the top; 1-4: the sides at ±x, ±y
    axis = np.where(face == 0, 2, (face - 1) // 2)
    u[np.arange(n_box), axis] = np.where(face == 0, 0.5, np.where((face - 1) % 2 == 0, -0.5, 0.5))
    boxes = np.column_stack([cx, cy, z0 + size[:, 2] / 2])[which] + u * size[which]
    top = max(hi[2], z0) + 0.2
    stray = rng.uniform([lo[0] - margin, lo[1] - margin, z0], [hi[0] + margin, hi[1] + margin, top], (n_stray, 3))
    return np.concatenate([boxes, stray])
