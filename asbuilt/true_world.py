"""A design built in a "true world": the synthetic as-built mattress with known truth.

The design's calibration says what the mattress does at its posterior median
(Δ̄, d̄). The workshop builds it in one true world instead: Equation 3's Δ and d
take their true values, and each string is cut (and tied) with an error e_i, its
real length l_i + e_i. :func:`built_world` inflates the design in such a world
(:class:`World`) the way :func:`airmat.check.inflation_check.check` inflates its
median run: the same mesh (the design's mattress at ``resolution``), the same
strings (ends on Ω, face), and rest lengths from the one chain of
:func:`airmat.check.string_world.world_strings`; a refined design from its
open-loop equilibrium (the design's median open-loop strings, inflated from the
flat mattress: the path, not the world), carried on to the world's strings. A
world equal to the calibration's median with no cut errors therefore gives
``check``'s median run itself.

The result (:class:`BuiltMattress`) is moved into Ŝ's frame the way ``check``
writes ``inflated.ply``: by the Kabsch alignment of the named face
(:func:`airmat.check.inflation_check.named_face`) to Ŝ. In that frame +z is up
(the designer's frame), so the face a scanner above the mattress sees is the
one whose normals point to +z (``BuiltMattress.upper_face``).

Cut errors
    e_i ~ Uniform(−c, c) by default (:func:`draw_cut_errors`): a workshop that
    cuts and ties "within ±3 mm" means every string within the band, none
    favoured; ``distribution="normal"`` draws N(0, (c/1.96)²) instead (±c its
    95 % interval). Each draw takes a seed; a world keeps the errors it drew
    (``World.cut_error``) and the ids they belong to (``World.ids``).

The correction cycle
    ``built_world(design, world, seed=s, recut=None)`` cuts every string anew: k
    fresh errors from ``seed``. After ``airmat correct``, the corrected design is
    built in the *same* world (Δ, d unchanged) where only the re-cut strings are
    cut again: ``built_world(corrected, first.world, seed=s2, recut=mask)``. A
    string with ``mask`` False keeps the error it was built with
    (``first.world.cut_error``, found by its id when the world has ids, else by
    its position); a re-cut string takes a fresh error. The fresh errors are drawn
    for all k strings and used where ``mask`` is True, so a string's new error does
    not depend on which others were re-cut. ``recut`` all False builds the world's
    errors exactly as given (a known error vector).

SI units: metres, 1/m. :func:`truth_dict` gives the world and the strings in mm
and 1/m, for truth.json.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace

import numpy as np

from airmat.check.compare import Deviation, deviation
from airmat.check.inflation_check import design_strings, named_face, open_loop_strings
from airmat.check.length_map import length_map
from airmat.check.string_world import WorldStrings, world_strings
from airmat.errors import InputError
from airmat.inflation.mesh import build_mattress_mesh
from airmat.inflation.model import Parameters
from airmat.inflation.simulate import Inflation, inflate, inflate_many
from airmat.inflation.strings import StringSet, check_resolution
from airmat.summary import Summarized, mm
from airmat.units import M_TO_MM

__all__ = ["World", "BuiltMattress", "CUT_DISTRIBUTIONS", "median_world", "draw_cut_errors", "built_world", "upper_face",
           "truth_dict"]

log = logging.getLogger(__name__)

#: how a cut error of tolerance c is drawn: uniform in [-c, c], or normal with c its 95 % half-width
CUT_DISTRIBUTIONS = ("uniform", "normal")

#: the 97.5 % quantile of the standard normal: N(0, (c/Z95)²) has ±c as its 95 % interval
_Z95 = 1.959963984540054


@dataclass(frozen=True)
class World:
    """The true world a design is built in.

    Attributes
    ----------
    delta, d : float
        Equation 3's string-end slip Δ and thickness d in this world (m).
    cut_tolerance : float
        c (m): every string is cut and tied within ±c (:func:`draw_cut_errors`).
    cut_error : ndarray of shape (k,) or None
        Real length minus design median length of each string as built (m); None: not built yet
        (every string is cut anew by :func:`built_world`).
    ids : tuple of str
        The string ids ``cut_error`` belongs to (empty: by position).
    seed : int or None
        Seed the fresh cut errors were drawn with (a record).
    distribution : {"uniform", "normal"}
        How a cut error is drawn.
    """

    delta: float
    d: float
    cut_tolerance: float = 0.0
    cut_error: np.ndarray | None = None
    ids: tuple = ()
    seed: int | None = None
    distribution: str = "uniform"

    def __post_init__(self):
        if not (np.isfinite(self.delta) and self.delta >= 0):
            raise InputError(f"World.delta must be a length >= 0 m, got {self.delta!r}", delta=self.delta)
        if not (np.isfinite(self.d) and self.d > 0):
            raise InputError(f"World.d must be a length > 0 m, got {self.d!r}", d=self.d)
        if not (np.isfinite(self.cut_tolerance) and self.cut_tolerance >= 0):
            raise InputError(f"World.cut_tolerance must be >= 0 m, got {self.cut_tolerance!r}",
                             cut_tolerance=self.cut_tolerance)
        if self.distribution not in CUT_DISTRIBUTIONS:
            raise InputError(f"cut-error distribution {self.distribution!r}: expected one of "
                             f"{', '.join(CUT_DISTRIBUTIONS)}")
        if self.cut_error is not None:
            e = np.asarray(self.cut_error, float)
            if e.ndim != 1 or (self.ids and len(self.ids) != len(e)) or not np.all(np.isfinite(e)):
                raise InputError(f"World.cut_error has shape {e.shape} (finite values expected, one per id: "
                                 f"{len(self.ids)} ids)")
            object.__setattr__(self, "cut_error", e)


def median_world(design, *, cut_tolerance: float = 0.0, distribution: str = "uniform") -> World:
    """The world the design's calibration predicts: Δ̄ and d̄, its posterior medians (m)."""
    cal = design.calibration
    return World(delta=float(cal.delta_median), d=float(np.median(cal.d)), cut_tolerance=cut_tolerance,
                 distribution=distribution)


def draw_cut_errors(k: int, cut_tolerance: float, *, seed=0, distribution: str = "uniform") -> np.ndarray:
    """k cut errors of tolerance c: Uniform(−c, c), or N(0, (c/1.96)²) (m).

    Parameters
    ----------
    k : int
        Number of strings.
    cut_tolerance : float
        c (m), >= 0.
    seed : int, sequence of int or numpy Generator
    distribution : {"uniform", "normal"}

    Returns
    -------
    ndarray of shape (k,)
        (m); zeros when c = 0.

    Examples
    --------
    >>> e = draw_cut_errors(1000, 0.003, seed=1)
    >>> bool(np.all(np.abs(e) <= 0.003)), e.shape
    (True, (1000,))
    """
    if not (np.isfinite(cut_tolerance) and cut_tolerance >= 0):
        raise InputError(f"cut tolerance must be >= 0 m, got {cut_tolerance!r}", cut_tolerance=cut_tolerance)
    if distribution not in CUT_DISTRIBUTIONS:
        raise InputError(f"cut-error distribution {distribution!r}: expected one of {', '.join(CUT_DISTRIBUTIONS)}")
    rng = np.random.default_rng(seed)
    if distribution == "uniform":
        return rng.uniform(-cut_tolerance, cut_tolerance, int(k))
    return rng.normal(0.0, cut_tolerance / _Z95, int(k))


@dataclass(frozen=True, repr=False)
class BuiltMattress(Summarized):
    """A design as built and inflated in a true world, in Ŝ's frame (SI).

    Attributes
    ----------
    world : World
        The world, with the cut errors the strings were built with (``cut_error`` (k,), ``ids``).
    strings : StringSet
        The strings as simulated: the design's ends and faces, the world's rest lengths l* (m).
    lengths : airmat.check.string_world.WorldStrings
        Per string: the curvature it makes in the world (1/m), the median-equivalent real length and
        the rest length (m).
    real_length : ndarray of shape (k,)
        Each string's real length as built: design median length plus cut error (m).
    inflation : Inflation
        The equilibrium, in the simulation frame.
    deviation : Deviation
        The named face against Ŝ; ``deviation.apply`` moves simulation points into Ŝ's frame.
    xyz : ndarray of shape (n, 3)
        The whole closed mattress (``inflation.mesh.faces``) in Ŝ's frame (m), as ``check``'s inflated.ply.
    upper_face : str
        ``"top"`` or ``"bottom"``: the face whose normals point to +z in Ŝ's frame (a scanner above sees it).
    upper_triangles : ndarray of shape (t, 3)
        That face's triangles on ``xyz``, oriented with their normals out of the mattress.
    resolution : float
        Edge length of the mesh (m).
    open_loop : Inflation or None
        A refined design's open-loop equilibrium the run was carried on from.
    """

    world: World
    strings: StringSet
    lengths: WorldStrings
    real_length: np.ndarray
    inflation: Inflation
    deviation: Deviation
    xyz: np.ndarray
    upper_face: str
    upper_triangles: np.ndarray
    resolution: float
    open_loop: Inflation | None = field(default=None)

    @property
    def surface(self) -> str:
        """The named face Ŝ stands for (``deviation.surface``)."""
        return self.deviation.surface

    @property
    def inflation_converged(self) -> bool:
        """True when the inflation (and a refined design's open-loop one) converged."""
        return bool(self.inflation.converged and (self.open_loop is None or self.open_loop.converged))

    def _summary(self):
        w, dev = self.world, self.deviation
        e = np.abs(w.cut_error) if w.cut_error is not None and len(w.cut_error) else np.zeros(1)
        return "BuiltMattress", [("Δ", mm(w.delta)), ("d", mm(w.d)), ("strings", len(self.strings)),
                                 ("|cut error| max", mm(float(e.max()))),
                                 ("deviation", f"{mm(dev.rms)} RMS ({dev.rms_pct_diag:.2f} % of the diagonal, "
                                               f"{dev.surface} face)"),
                                 ("converged", self.inflation_converged)]


def _cut_errors(design, world: World, seed, recut) -> np.ndarray:
    """Each design string's cut error as built (m): fresh ones where ``recut``, the world's elsewhere."""
    ids = tuple(s.dash.id for s in design.pattern.strings)
    k = len(ids)
    fresh = draw_cut_errors(k, world.cut_tolerance, seed=seed, distribution=world.distribution)
    if recut is None:
        return fresh
    mask = np.asarray(recut)
    if mask.dtype != bool or mask.shape != (k,):
        raise InputError(f"recut must be a boolean mask of shape ({k},) (one per string), got {mask.dtype} "
                         f"of shape {mask.shape}")
    if mask.all():
        return fresh
    if world.cut_error is None:
        raise InputError("recut keeps some strings as built, but the world has no cut errors (World.cut_error)")
    kept = world.cut_error
    if world.ids:
        where = {sid: i for i, sid in enumerate(world.ids)}
        missing = [sid for sid, m in zip(ids, mask) if not m and sid not in where]
        if missing:
            raise InputError(f"strings kept as built but not in the world's cut errors: {', '.join(missing[:5])}"
                             f"{' ...' if len(missing) > 5 else ''}", ids=missing)
        kept = np.array([kept[where[sid]] if sid in where else 0.0 for sid in ids])
    elif kept.shape != (k,):
        raise InputError(f"World.cut_error has shape {kept.shape}, expected ({k},) (one per string of the design)")
    return np.where(mask, fresh, kept)


def built_world(design, world: World, *, resolution: float = 0.020, params: Parameters = Parameters(),
                seed=0, recut=None, strict: bool = False) -> BuiltMattress:
    """Build and inflate ``design`` in ``world``; the result in Ŝ's frame.

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
        In memory or read from its folder (:func:`airmat.design.design_io.read_design`).
    world : World
        Δ, d (m), the cut tolerance c and, for strings kept as built, their cut errors.
    resolution : float
        Edge length of the double-layer mesh (m), as ``check``'s.
    params : Parameters
        Pressure and stiffnesses of U_B.
    seed : int, sequence of int or numpy Generator
        Seed of the fresh cut errors (:func:`draw_cut_errors`).
    recut : ndarray of shape (k,) of bool, optional
        Which strings are cut anew (fresh errors); the others keep ``world.cut_error``. None: all.
    strict : bool
        Raise :class:`airmat.errors.ConvergenceError` when an inflation does not converge.

    Returns
    -------
    BuiltMattress
        ``world`` with ``cut_error`` (k,), ``ids`` and ``seed`` of this build.

    Raises
    ------
    airmat.errors.InputError
        A resolution too coarse for the strings, a ``recut`` mask of the wrong shape, kept strings
        without errors in the world.
    """
    e = _cut_errors(design, world, seed, recut)
    strings = design.pattern.strings
    world = replace(world, cut_error=e, ids=tuple(s.dash.id for s in strings),
                    seed=seed if isinstance(seed, (int, np.integer)) else world.seed)
    lengths = length_map(design.calibration)
    median = design_strings(design, lengths=lengths)
    check_resolution(median, resolution)
    ws = world_strings(design, world.delta, world.d, cut_error=e, lengths=lengths)
    string_set = replace(median, rest=np.asarray(ws.rest, float))
    m = design.mattress
    mesh = build_mattress_mesh(m.width, m.height, m.thickness, resolution=resolution)
    start = open_loop_strings(design, lengths=lengths)
    base = None
    if start is not None:       # a refined design: from its open-loop equilibrium, as check inflates it
        base = inflate(mesh, start if len(start) else None, params=params, strict=strict)
    inf = inflate_many(mesh, [string_set if len(string_set) else None], params=params, strict=strict,
                       start=base)[0]
    if not inf.converged:
        log.warning("the as-built inflation did not converge: %s", inf.message)
    dev = deviation(inf, design.approx.xyz, design.approx.uv, named_face(design, string_set))
    xyz = dev.apply(inf.xyz)
    upper, triangles = upper_face(inf.mesh, xyz)
    log.info("built in Δ = %.1f mm, d = %.1f mm: %d Newton iterations in %.1f s; %s face %.1f mm RMS from Ŝ",
             world.delta * M_TO_MM, world.d * M_TO_MM, inf.n_iter, inf.seconds, dev.surface, dev.rms * M_TO_MM)
    return BuiltMattress(world=world, strings=string_set, lengths=ws,
                         real_length=np.array([s.l_median for s in strings], float) + e, inflation=inf,
                         deviation=dev, xyz=xyz, upper_face=upper, upper_triangles=triangles,
                         resolution=float(resolution),
                         open_loop=None if base is None else replace(base, mesh=mesh, levels=()))


def upper_face(mesh, xyz) -> tuple:
    """The face a scanner above the mattress sees: the one whose outward normals point to +z on the whole.

    Parameters
    ----------
    mesh : airmat.inflation.mesh.MattressMesh
    xyz : ndarray of shape (n, 3)
        The mattress's vertices in a frame whose +z is up (m).

    Returns
    -------
    name : str
        ``"top"`` or ``"bottom"``.
    triangles : ndarray of shape (t, 3)
        Its triangles, outward oriented, as indices into ``xyz``.
    """
    top = mesh.top[mesh.grid_faces]                 # CCW seen from above in the flat mattress: outward
    bottom = mesh.bottom[mesh.grid_faces[:, ::-1]]
    nz = np.cross(xyz[top[:, 1]] - xyz[top[:, 0]], xyz[top[:, 2]] - xyz[top[:, 0]])[:, 2]
    return ("top", top) if nz.sum() >= 0 else ("bottom", bottom)


def truth_dict(built: BuiltMattress, design=None) -> dict:
    """The world and the strings of a built mattress in mm and 1/m (truth.json's part).

    Parameters
    ----------
    built : BuiltMattress
    design : airmat.design.pipeline.DesignResult, optional
        Adds the calibration's medians, the world the design was made for.

    Returns
    -------
    dict
        ``world`` (Δ, d, c, distribution, seed), ``strings`` (id, side, design and real length,
        cut error, median-equivalent and simulated rest length, world curvature), ``inflation``
        (convergence) and ``deviation`` (the named face from Ŝ).
    """
    w, dev, inf = built.world, built.deviation, built.inflation
    s = built.strings
    rows = [{"id": sid, "side": "top" if top else "bottom",
             "l_design_mm": (real - err) * M_TO_MM, "cut_error_mm": err * M_TO_MM, "l_real_mm": real * M_TO_MM,
             "l_median_equivalent_mm": eq * M_TO_MM, "rest_mm": rest * M_TO_MM, "kappa_per_m": kap}
            for sid, top, real, err, eq, rest, kap in zip(
                s.ids, s.top.tolist(), built.real_length.tolist(), w.cut_error.tolist(),
                np.ravel(built.lengths.length).tolist(), s.rest.tolist(), np.ravel(built.lengths.kappa).tolist())]
    doc = {"world": {"delta_mm": w.delta * M_TO_MM, "d_mm": w.d * M_TO_MM,
                     "cut_tolerance_mm": w.cut_tolerance * M_TO_MM, "cut_distribution": w.distribution,
                     "seed": w.seed},
           "strings": rows,
           "resolution_mm": built.resolution * M_TO_MM,
           "inflation": {"converged": built.inflation_converged, "iterations": int(inf.n_iter),
                         "residual": float(inf.residual), "message": inf.message},
           "deviation": {"surface": dev.surface, "rms_mm": dev.rms * M_TO_MM, "max_mm": dev.max * M_TO_MM,
                         "rms_pct_diag": dev.rms_pct_diag},
           "upper_face": built.upper_face}
    if design is not None:
        med = median_world(design)
        doc["world"]["design_median"] = {"delta_mm": med.delta * M_TO_MM, "d_mm": med.d * M_TO_MM}
    return doc
