"""A zoo of target surfaces S for the designer: every kind of shape the paper's method meets, seeded.

:func:`zoo` returns :class:`ZooEntry` objects: a triangle mesh in metres (normals up,
the mattress's top face goes on that side), the mattress to make it from as plain
numbers (W, H in metres), the units its file is written in (``"mm"`` or ``"m"``:
the mesh is always metres here; a benchmark writes the file in those units and reads it
back as a user's file would be), and what the designer is expected to say:

- ``constructible``: whether Ŝ passes the paper's σ criterion (§3.2: every edge of Ŝ
  within the band of its length on Ω, the designer's ``design.approx.report.constructible``).
  The expectation comes from the geometry, not from a run: a developable surface
  (cylinders, cones, vaults, waves, helicoids of long pitch) has a Ŝ that keeps Ω's
  lengths; a patch of Gaussian curvature K spanning a half-width a strains the membrane
  by about |K| a² / 6 (a geodesic disk's perimeter), so shapes with |K| a² / 6 well
  below the band's 10 % are constructible and those well above it (domes, tight
  helicoids, egg crates) are not;
  The designer's fold route (``airmat.design.fold_route``) then searches, for a target that
  is not, a Ŝ whose σ keeps to the paper's 0.93–1.07 by folding (or, on a saddle, by
  flattening), so its final verdict may be yes;
- ``refused``: the designer refuses the target before any work (a size 0.2 to 50
  times the mattress's diagonal is accepted, :func:`airmat.design.target.check_scale`;
  outside that it is a units slip: exit code 2 on the command line).

The kinds (:data:`KINDS`) cover cylinders and cones of several radii, positions and
tilts; hyperbolic paraboloids with |κ₂| / |κ₁| from 0.3 to 1; waves whose curvature
changes sign once and twice; elliptic and catenary vaults; a conoid and helicoid
patches; near-developable freeforms (seeded); domes and other non-developable shapes;
targets larger and smaller than the mattress, rotated and offset in space, coarse and
fine, uniform and irregular (seeded) triangulations, in mm and in m, on both mattress
sizes. Each entry keeps its local frame (``rotation``, ``offset``: world = R · local +
offset) and its parameters, so tests can check the geometry exactly.

This module imports nothing from the designer (``airmat.design``).

Examples
--------
>>> entries = zoo()
>>> len(entries) >= 24, sorted({e.kind for e in entries}) == sorted(KINDS)
(True, True)
>>> e = by_name("cylinder-r300")
>>> e.mattress, e.units, e.constructible
((0.83, 0.74), 'm', True)
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from airmat.constants import LARGE_MATTRESS, SMALL_MATTRESS
from airmat.synthetic import zoo_shapes as zs

__all__ = ["ZooEntry", "zoo", "by_name", "names", "QUICK", "KINDS", "SIZES"]

#: mattress sizes (W, H) in metres by name
SIZES = {"small": tuple(SMALL_MATTRESS), "large": tuple(LARGE_MATTRESS)}

#: every kind of target the zoo holds
KINDS = ("cylinder", "cone", "hypar", "wave-1", "wave-2", "elliptic-vault", "catenary-vault", "conoid",
         "helicoid", "freeform", "dome", "non-developable")

#: three small targets of different kinds for a quick run (a cylinder, a hypar, a dome)
QUICK = ("cylinder-r300", "hypar-0.6", "dome-r450")


@dataclass(frozen=True)
class ZooEntry:
    """One target of the zoo.

    Attributes
    ----------
    name : str
    kind : str
        One of :data:`KINDS`.
    vertices : ndarray of shape (n, 3)
        (m), normals up.
    faces : ndarray of shape (m, 3), int64
    size : str
        ``"small"`` or ``"large"``: the mattress (:data:`SIZES`).
    mattress : (float, float)
        W, H of the mattress (m).
    units : str
        ``"m"`` or ``"mm"``: the units its file is written in.
    constructible : bool
        Expected verdict of the σ criterion (the module docstring says how it is set).
    refused : bool
        Expected refusal of the target's size (then ``constructible`` is False).
    triangulation : str
        ``"uniform"`` or ``"irregular"``.
    spacing : float
        Mesh spacing (m), the irregular mesh's mean.
    rotation : ndarray of shape (3, 3)
    offset : ndarray of shape (3,)
        The rigid motion from the local frame: world = rotation @ local + offset (m).
    params : dict
        The surface's parameters in its local frame (m, 1/m, rad).
    note : str
        What the entry tests.
    """

    name: str
    kind: str
    vertices: np.ndarray = field(repr=False)
    faces: np.ndarray = field(repr=False)
    size: str
    mattress: tuple
    units: str
    constructible: bool
    refused: bool = False
    triangulation: str = "uniform"
    spacing: float = 0.02
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3), repr=False)
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3), repr=False)
    params: dict = field(default_factory=dict, repr=False)
    note: str = ""

    @property
    def local(self) -> np.ndarray:
        """Vertices (n, 3) in the surface's local frame (m)."""
        return (self.vertices - self.offset) @ self.rotation

    @property
    def bbox_diagonal(self) -> float:
        """Bounding-box diagonal of the mesh (m)."""
        return float(np.linalg.norm(np.ptp(self.vertices, axis=0)))


def _entry(name, kind, fn, s_range, t_range, *, size="small", spacing=0.02, irregular=False, rng=None,
           degrees=(0.0, 0.0, 0.0), offset=(0.0, 0.0, 0.0), scale=1.0, units="m", constructible=True,
           refused=False, params=None, note=""):
    v, f = zs.mesh_patch(fn, s_range, t_range, spacing=spacing, irregular=irregular, rng=rng)
    rot, off = zs.rotation(degrees), np.asarray(offset, float)
    return ZooEntry(name=name, kind=kind, vertices=zs.rigid(v * scale, rot, off), faces=f, size=size,
                    mattress=SIZES[size], units=units, constructible=constructible and not refused, refused=refused,
                    triangulation="irregular" if irregular else "uniform", spacing=spacing * scale, rotation=rot,
                    offset=off, params=dict(params or {}), note=note)


def _hypar(k1, ratio):
    """z = −(κ₁ x² − ratio κ₁ y²) / 2: κ = κ₁ along x (a vault), −ratio κ₁ along y, at the origin."""
    return zs.graph_map(lambda x, y: -0.5 * k1 * (x ** 2 - ratio * y ** 2))


def _ellipse(a, b, half_angle):
    """The upper arc of the ellipse (a sin u, b cos u − b), |u| ≤ half_angle, by arc length, toward −x."""
    u = np.linspace(half_angle, -half_angle, 20001)          # odd: u = 0, the crown, is the middle sample
    x, z = a * np.sin(u), b * np.cos(u) - b
    crown = float(np.hypot(np.diff(x), np.diff(z))[:len(u) // 2].sum())
    return zs.plane_curve(x, z, crown)


def _freeform(rng, kappa0, amplitude, wavelength, n_modes=4):
    """A vault z = −κ0 y² / 2 (κ0 varying ±30 % along x) plus a few seeded low-frequency modes."""
    k = 2 * np.pi / wavelength * rng.uniform(0.5, 1.0, (n_modes, 2))
    phase, amp = rng.uniform(0, 2 * np.pi, n_modes), amplitude * rng.uniform(0.5, 1.0, n_modes)
    vary = rng.uniform(0, 2 * np.pi)

    def h(x, y):
        kap = kappa0 * (1 + 0.3 * np.sin(2 * np.pi * x / (2 * wavelength) + vary))
        modes = (amp[None, :] * np.cos(x[:, None] * k[None, :, 0] + y[:, None] * k[None, :, 1]
                                        + phase[None, :])).sum(axis=1)
        return -0.5 * kap * y ** 2 + modes
    return zs.graph_map(h), {"kappa0": kappa0, "amplitude": amplitude, "wavelength": wavelength,
                             "k": k.tolist(), "phase": phase.tolist(), "amp": amp.tolist()}


def _cylinders(rng):
    small_s, small_t = (-0.55, 0.55), (-0.5, 0.5)
    return [
        _entry("cylinder-r300", "cylinder", zs.cylinder_map(0.3), small_s, small_t, params={"radius": 0.3},
               note="the paper's vault range (κ 3.3 1/m)"),
        _entry("cylinder-r200-mm", "cylinder", zs.cylinder_map(0.2), small_s, (-0.47, 0.47), units="mm",
               params={"radius": 0.2}, note="tight (κ 5 1/m), file in mm"),
        _entry("cylinder-r400-tilted", "cylinder", zs.cylinder_map(0.4), small_s, small_t, degrees=(25, -15, 40),
               offset=(1.5, -0.7, 2.0), params={"radius": 0.4}, note="rotated and offset in space"),
        _entry("cylinder-r350-irregular", "cylinder", zs.cylinder_map(0.35), small_s, small_t, irregular=True,
               rng=rng, spacing=0.025, params={"radius": 0.35}, note="graded, jittered Delaunay mesh"),
        _entry("cylinder-r300-offcrown", "cylinder", zs.cylinder_map(0.3), small_s, (-0.25, 0.8),
               params={"radius": 0.3}, note="the crown near one rim: Ω sits to one side of it"),
        _entry("cylinder-r300-coarse", "cylinder", zs.cylinder_map(0.3), small_s, small_t, spacing=0.08,
               params={"radius": 0.3}, note="80 mm mesh: facets of 15°"),
        _entry("cylinder-r300-fine", "cylinder", zs.cylinder_map(0.3), small_s, small_t, spacing=0.007,
               params={"radius": 0.3}, note="7 mm mesh"),
        _entry("cylinder-r800-large", "cylinder", zs.cylinder_map(0.8), (-1.5, 1.5), (-1.0, 1.0), size="large",
               spacing=0.03, units="mm", params={"radius": 0.8}, note="large mattress, file in mm"),
        _entry("cylinder-r600-big-sheet", "cylinder", zs.cylinder_map(0.6), (-1.5, 1.5), (-1.25, 1.25),
               spacing=0.03, params={"radius": 0.6}, note="3 times the small mattress: Ω covers part of it"),
        _entry("cylinder-r300-small-patch", "cylinder", zs.cylinder_map(0.3), (-0.3, 0.3), (-0.25, 0.25),
               params={"radius": 0.3}, note="smaller than the mattress: Ŝ continues S by its tangent planes"),
        _entry("cylinder-tiny-refused", "cylinder", zs.cylinder_map(0.1), (-0.07, 0.07), (-0.06, 0.06),
               spacing=0.005, refused=True, params={"radius": 0.1}, note="0.17 times the mattress diagonal"),
        _entry("cylinder-mm-read-as-m", "cylinder", zs.cylinder_map(0.3), small_s, small_t, scale=1000.0,
               refused=True, params={"radius": 300.0}, note="a file in mm read as metres: 1000 times too large"),
    ]


def _cones():
    return [
        _entry("cone-r300", "cone", zs.cone_map(0.3, 0.2), (-0.55, 0.55), (-0.5, 0.5),
               params={"r_crown": 0.3, "half_angle": 0.2}, note="κ 2.5 to 5 1/m along the crown"),
        _entry("cone-r350-steep-rotated", "cone", zs.cone_map(0.35, 0.35), (-0.55, 0.55), (-0.5, 0.5),
               degrees=(0, 0, 90), offset=(0.2, 0.3, -0.1), params={"r_crown": 0.35, "half_angle": 0.35},
               note="κ 2 to 6 1/m, axis turned across the mattress"),
        _entry("cone-r900-large", "cone", zs.cone_map(0.9, 0.15), (-1.5, 1.5), (-1.0, 1.0), size="large",
               spacing=0.03, degrees=(10, 0, 0), params={"r_crown": 0.9, "half_angle": 0.15},
               note="large mattress, tilted"),
    ]


def _hypars():
    e = (-0.55, 0.55), (-0.5, 0.5)
    return [
        _entry("hypar-0.3", "hypar", _hypar(2.5, 0.3), *e, params={"k1": 2.5, "ratio": 0.3},
               note="|κ₂| / |κ₁| = 0.3"),
        _entry("hypar-0.6", "hypar", _hypar(2.0, 0.6), *e, units="mm", params={"k1": 2.0, "ratio": 0.6},
               note="|κ₂| / |κ₁| = 0.6, file in mm"),
        _entry("hypar-1.0", "hypar", _hypar(1.5, 1.0), *e, params={"k1": 1.5, "ratio": 1.0},
               note="equal magnitudes"),
        _entry("hypar-1.0-xy", "hypar", zs.graph_map(lambda x, y: -1.5 * x * y), *e, degrees=(0, 0, 30),
               params={"k1": 1.5, "ratio": 1.0}, note="z = −1.5 xy: equal magnitudes along the diagonals"),
        _entry("hypar-1.0-k2", "hypar", _hypar(2.0, 1.0), (-0.5, 0.5), (-0.45, 0.45),
               params={"k1": 2.0, "ratio": 1.0}, note="equal magnitudes at ±2 1/m over 1.0 × 0.9 m"),
        _entry("hypar-1.0-strong", "hypar", _hypar(4.0, 1.0), *e, constructible=False,
               params={"k1": 4.0, "ratio": 1.0}, note="K = −16 1/m²: beyond the membrane's strain"),
        _entry("hypar-0.5-large", "hypar", _hypar(0.8, 0.5), (-1.5, 1.5), (-1.0, 1.0), size="large", spacing=0.03,
               params={"k1": 0.8, "ratio": 0.5}, note="large mattress"),
    ]


def _waves():
    once = lambda s: 3.0 * np.sin(np.pi * s / 1.0)                  # noqa: E731  one sign change, at s = 0
    twice = lambda s: 3.0 * np.cos(np.pi * s / 0.7)                 # noqa: E731  two, at s = ±0.35 m
    twice_large = lambda s: 1.5 * np.cos(np.pi * s / 1.2)           # noqa: E731  two, at s = ±0.6 m
    return [
        _entry("wave-once", "wave-1", zs.profile_map(*zs.curvature_profile(once, (-0.5, 0.5))), (-0.55, 0.55),
               (-0.5, 0.5), params={"kappa": "3 sin(π σ / 1 m)"}, note="strings on both faces"),
        _entry("wave-twice", "wave-2", zs.profile_map(*zs.curvature_profile(twice, (-0.5, 0.5))), (-0.55, 0.55),
               (-0.5, 0.5), params={"kappa": "3 cos(π σ / 0.7 m)"}, note="an S-curve each side of a crown"),
        _entry("wave-twice-large", "wave-2", zs.profile_map(*zs.curvature_profile(twice_large, (-1.0, 1.0))),
               (-1.5, 1.5), (-1.0, 1.0), size="large", spacing=0.03, params={"kappa": "1.5 cos(π σ / 1.2 m)"},
               note="large mattress"),
    ]


def _vaults():
    c, c_large = 0.3, 0.8
    cat = lambda c: (lambda s: c / (c ** 2 + s ** 2))              # noqa: E731  κ(σ) of z = −c cosh(x / c)
    return [
        _entry("vault-elliptic", "elliptic-vault", zs.profile_map(*_ellipse(0.55, 0.35, 1.2)), (-0.55, 0.55),
               (-0.5, 0.5), params={"a": 0.55, "b": 0.35}, note="κ 1.2 at the crown to 3.6 1/m at the springs"),
        _entry("vault-catenary", "catenary-vault", zs.profile_map(*zs.curvature_profile(cat(c), (-0.5, 0.5))),
               (-0.55, 0.55), (-0.5, 0.5), params={"c": c}, note="κ = c / (c² + σ²): 3.3 1/m at the crown"),
        _entry("vault-catenary-large", "catenary-vault",
               zs.profile_map(*zs.curvature_profile(cat(c_large), (-1.0, 1.0))), (-1.5, 1.5), (-1.0, 1.0),
               size="large", spacing=0.03, units="mm", params={"c": c_large}, note="large mattress, file in mm"),
    ]


def _ruled():
    conoid = zs.graph_map(lambda x, y: -((y + 0.5) / 1.0) * x ** 2 / (2 * 0.5))
    return [
        _entry("conoid", "conoid", conoid, (-0.55, 0.55), (-0.5, 0.5), params={"R": 0.5, "Y": 0.5},
               note="from a straight rim to a vault of κ 2 1/m: ruled, K < 0 (up to −1 1/m²)"),
        _entry("helicoid-p2000", "helicoid", zs.helicoid_map(2.0), (-0.55, 0.55), (-0.5, 0.5),
               params={"pitch": 2.0}, note="a gentle twist (0.55 rad over the mattress), K ≥ −0.25 1/m²"),
        _entry("helicoid-p500", "helicoid", zs.helicoid_map(0.5), (-0.55, 0.55), (-0.5, 0.5), constructible=False,
               params={"pitch": 0.5}, note="a tight twist (2.2 rad), K = −4 1/m² on the axis"),
    ]


def _freeforms(rng):
    small, p_small = _freeform(rng, 2.5, 0.004, 0.6)
    large, p_large = _freeform(rng, 1.2, 0.01, 1.5)
    return [
        _entry("freeform-small", "freeform", small, (-0.55, 0.55), (-0.5, 0.5), params=p_small,
               note="a vault with seeded ripples: near-developable"),
        _entry("freeform-large-irregular", "freeform", large, (-1.5, 1.5), (-1.0, 1.0), size="large", spacing=0.04,
               irregular=True, rng=rng, degrees=(0, 5, -20), offset=(10.0, 20.0, 0.5), params=p_large,
               note="large mattress, irregular mesh, far from the origin"),
    ]


def _domes():
    egg = zs.graph_map(lambda x, y: 0.04 * np.sin(2 * np.pi * x / 0.5) * np.sin(2 * np.pi * y / 0.5))
    return [
        _entry("dome-r450", "dome", zs.sphere_map(0.45), (-0.55, 0.55), (-0.5, 0.5), constructible=False,
               params={"radius": 0.45}, note="K = 4.9 1/m²: the paper's dome needs folds"),
        _entry("dome-r3000-shallow", "dome", zs.sphere_map(3.0), (-0.55, 0.55), (-0.5, 0.5),
               params={"radius": 3.0}, note="K = 0.11 1/m²: double-curved but within the strain"),
        _entry("dome-r1000-large", "dome", zs.sphere_map(1.0), (-1.5, 1.5), (-1.0, 1.0), size="large", spacing=0.03,
               constructible=False, params={"radius": 1.0}, note="large mattress, K = 1 1/m² over 3 m"),
        _entry("egg-crate", "non-developable", egg, (-0.55, 0.55), (-0.5, 0.5), spacing=0.015, constructible=False,
               params={"amplitude": 0.04, "wavelength": 0.5}, note="K of both signs, |K| up to 40 1/m²"),
    ]


def zoo(*, seed: int = 0) -> list:
    """Every target of the zoo, in a fixed order (the module docstring lists them).

    Parameters
    ----------
    seed : int
        Seed of the irregular triangulations and the freeforms' ripples; the same seed
        gives the same meshes bit for bit.

    Returns
    -------
    list of ZooEntry
    """
    rng = np.random.default_rng(seed)
    return [*_cylinders(rng), *_cones(), *_hypars(), *_waves(), *_vaults(), *_ruled(), *_freeforms(rng),
            *_domes()]


def names(*, seed: int = 0) -> list:
    """The names of :func:`zoo`'s entries, in order."""
    return [e.name for e in zoo(seed=seed)]


def by_name(name: str, *, seed: int = 0) -> ZooEntry:
    """One entry of :func:`zoo` by its name.

    Raises
    ------
    KeyError
        For an unknown name (the message lists the names).
    """
    for e in zoo(seed=seed):
        if e.name == name:
            return e
    raise KeyError(f"no zoo target {name!r}: choose one of {', '.join(names(seed=seed))}")
