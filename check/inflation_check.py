"""The inflation check of a design: inflate at the median string lengths and at both tolerance ends.

:func:`check` reads nothing and writes nothing: give it the
:class:`~airmat.design.pipeline.DesignResult` of :func:`airmat.design.pipeline.design` (or
of :func:`airmat.design.design_io.read_design`); it builds the double-layer mesh,
inflates it three times (strings at their median, lo95 and hi95 lengths,
each simulated at l + 2Δ with Δ the calibration's posterior median, or through
the calibrated length map with ``calibrated_map=True``: :mod:`airmat.check.length_map`) and
compares each result with Ŝ on the named face (:func:`named_face`: the face
whose metric Ŝ was relaxed in, else the face opposite the larger share of
bending |κ| × span, the face that keeps Ω's lengths as Ŝ does), with the
other faces for reference. SI units.

With ``samples=K`` it also inflates K Monte-Carlo samples of the string lengths
(:func:`airmat.check.monte_carlo.draw`: the posterior of (Δ, d, σ) and each string's own
scatter), in the same batch as the three runs, and summarizes their deviations on
the same face (:func:`airmat.check.monte_carlo.summarize`).

A refined design (:mod:`airmat.check.refinement`) is inflated the way it was refined:
its open-loop strings (``design.open_loop``) from the flat mattress, and that
equilibrium carried on to each run's strings
(:func:`~airmat.inflation.simulate.inflate_from`; ``DesignCheck.open_loop``). The
refinement's trial equilibria all lie on that path, each started from the last
one; from the flat mattress the same lengths can settle in another
arrangement of the wrinkles (vault1: 7.1 instead of 6.4 mm RMS; ``docs/benchmarks.md``,
``bench/bench_refine.py --from-flat``).

The three runs are independent, so ``workers > 1`` runs them in that many
Dask worker processes, or ``scheduler`` on an existing cluster
(:func:`~airmat.inflation.simulate.inflate_many`, :mod:`airmat.inflation.executor`).
An inflation already made the check's way (a :class:`KnownRun`, e.g. the
verification of :func:`airmat.check.refinement.refine`) stands in for the median run
(or the open-loop equilibrium) when it is that run: same strings, start, mesh,
parameters and tolerance.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import numpy as np

from airmat.errors import InputError
from airmat.check.compare import (SURFACES, Deviation, TargetDistance, deviation, distance_to_target,
                                  realized_curvature)
from airmat.design.face_metric import strings_named_face
from airmat.check.length_map import length_map
from airmat.check.monte_carlo import draw, summarize
from airmat.inflation.mesh import build_mattress_mesh
from airmat.inflation.model import Parameters
from airmat.inflation.simulate import INFLATE_TOL, Inflation, inflate, inflate_many
from airmat.inflation.strings import StringSet, check_resolution
from airmat.summary import Summarized, mm

__all__ = ["CheckRun", "DesignCheck", "KnownRun", "check", "monte_carlo", "design_strings", "open_loop_strings", "named_face",
           "LENGTH_KEYS"]

log = logging.getLogger(__name__)

#: the string lengths a check can inflate with
LENGTH_KEYS = ("median", "lo95", "hi95")


@dataclass(frozen=True)
class KnownRun:
    """An inflation made the check's way (flat start, ramp, continuation; or carried on from ``start``'s
    equilibrium), to stand in for a run of :func:`check`.

    Attributes
    ----------
    strings : StringSet
        What was inflated (rest lengths l*, m); an empty set for no strings.
    inflation : Inflation
    params : Parameters
    tol : float
        Its force residual.
    start : StringSet, optional
        The strings whose equilibrium it was carried on from (a refined design's open loop,
        :func:`open_loop_strings`); None: inflated from the flat mattress.
    """

    strings: StringSet
    inflation: Inflation
    params: Parameters
    tol: float
    start: StringSet | None = None

    def stands_for(self, strings: StringSet, mesh, params: Parameters, tol: float,
                   start: StringSet | None = None) -> bool:
        """True when this is the inflation :func:`check` would make of ``strings`` on ``mesh``, from the
        equilibrium of ``start`` (None: from the flat mattress)."""
        m = self.inflation.mesh
        return (self.params == params and self.tol == tol and m is not None
                and m.n_vertices == mesh.n_vertices and np.array_equal(m.spacing, mesh.spacing)
                and _same(self.strings, strings) and _same(self.start, start))


def _same(mine: StringSet | None, other: StringSet | None) -> bool:
    if mine is None or other is None:
        return mine is None and other is None
    return all(np.array_equal(getattr(mine, f), getattr(other, f)) for f in ("a", "b", "top", "rest"))


def design_strings(design, which: str = "median", *, lengths=None) -> StringSet:
    """A design's strings at one end of their tolerance, as the simulator takes them (SI).

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
    which : {"median", "lo95", "hi95"}
        Which length of each string.
    lengths : airmat.check.length_map.LengthMap or CalibratedLengthMap, optional
        Real length -> simulated rest length; default ``length_map(design.calibration)``.

    Returns
    -------
    StringSet
        Ends on Ω (m) and the simulated rest length (m): by default l* = l + 2Δ,
        Δ the posterior median of the design's calibration (the simulated ends do
        not slip, Equation 3's l*); with a calibrated map, the rest length at which
        the simulated specimen bends as the calibrated Equation 3 says.
    """
    lengths = length_map(design.calibration) if lengths is None else lengths
    return _string_set(design.pattern.strings, which, lengths)


def open_loop_strings(design, *, lengths=None) -> StringSet | None:
    """The open-loop strings a refined design's inflations start from, at their median lengths (SI).

    :func:`check` inflates them from the flat mattress and carries that equilibrium on to
    each run's strings (:func:`~airmat.inflation.simulate.inflate_from`), the path the
    refinement's equilibria took. ``lengths`` as in :func:`design_strings`.

    Returns
    -------
    StringSet or None
        None when the design was not refined (its runs start from the flat mattress).
    """
    if design.open_loop is None:
        return None
    lengths = length_map(design.calibration) if lengths is None else lengths
    return _string_set(design.open_loop, "median", lengths)


def _string_set(strings, which: str, lengths) -> StringSet:
    """TensionStrings as the simulator takes them: ends on Ω and l* = ``lengths.to_simulated(l_which)`` (m)."""
    k = len(strings)
    a = np.array([s.dash.a for s in strings], float).reshape(k, 2)
    b = np.array([s.dash.b for s in strings], float).reshape(k, 2)
    top = np.array([s.side == "top" for s in strings], bool)
    length = np.array([getattr(s, f"l_{which}") for s in strings], float)
    return StringSet(a, b, top, lengths.to_simulated(length),
                     tuple(s.dash.id for s in strings))


@dataclass(frozen=True, repr=False)
class CheckRun(Summarized):
    """One inflation of the design and how far it lands from Ŝ.

    Attributes
    ----------
    which : str
        ``"median"``, ``"lo95"`` or ``"hi95"``: the string lengths used.
    inflation : airmat.inflation.simulate.Inflation
    deviation : airmat.check.compare.Deviation
        On the named face (``DesignCheck.surface``).
    kappa_realized : ndarray of shape (k,)
        Signed curvature realized along each string's dash on the named face (1/m).
    deviations : dict of str -> Deviation
        Every face (``"top"``, ``"bottom"``, ``"mid"``), the named one included, for reference.
    kappa_realized_free : ndarray of shape (k,)
        Along each dash on the face opposite its own string (the face that keeps its length
        in the paper's Figure 4a; the named face for the majority side's strings) (1/m).
    to_target : airmat.check.compare.TargetDistance or None
        The aligned named face's distance to the user's target S (closest points,
        :func:`airmat.check.compare.distance_to_target`); None when the design does not
        keep S (``design.approx.target`` is None: a folder written before ``target.ply``).
    """

    which: str
    inflation: Inflation
    deviation: Deviation
    kappa_realized: np.ndarray
    deviations: dict = None
    kappa_realized_free: np.ndarray = None
    to_target: TargetDistance | None = None


    def _summary(self):
        return f"CheckRun {self.which}", [("deviation", f"{mm(self.deviation.rms)} RMS, {mm(self.deviation.max)} max "
                                                      f"({self.deviation.rms_pct_diag:.2f} % of the diagonal)"),
                                          ("face", self.deviation.surface), ("converged", self.inflation.converged)]


@dataclass(frozen=True, repr=False)
class DesignCheck(Summarized):
    """The median run and the tolerance envelope (``runs['median' | 'lo95' | 'hi95']``).

    Attributes
    ----------
    design : airmat.design.pipeline.DesignResult
    resolution : float
        Edge length of the double-layer mesh (m).
    runs : dict of str -> CheckRun
    surface : str
        The face Ŝ stands for, on which each run's ``deviation`` and ``kappa_realized``
        are measured (``"top"``, ``"bottom"`` or ``"mid"``).
    lengths : LengthMap or CalibratedLengthMap
        The real -> simulated string length map the runs used.
    monte_carlo : airmat.check.monte_carlo.MonteCarloResult or None
        The Monte-Carlo samples' deviations on the same face, when asked for.
    open_loop : airmat.inflation.simulate.Inflation or None
        A refined design's open-loop equilibrium (from the flat mattress), which every run was
        carried on from; None: every run was inflated from the flat mattress.
    tolerance : airmat.check.tolerance.LinearTolerance or None
        The tolerance to first order (:func:`airmat.check.tolerance.tolerance` of this check), when asked for.
    approx_to_target : airmat.check.compare.TargetDistance or None
        Ŝ's own distance to the user's target S (its vertices, % of Ŝ's diagonal), the floor
        under each run's ``to_target``; None when the design does not keep S.
    """

    design: object
    resolution: float
    runs: dict
    surface: str = "mid"
    lengths: object = None
    monte_carlo: object = None
    open_loop: Inflation | None = None
    tolerance: object = None
    approx_to_target: TargetDistance | None = None


    def _summary(self):
        rows = [(k, f"{mm(r.deviation.rms)} RMS, {mm(r.deviation.max)} max "
                    f"({r.deviation.rms_pct_diag:.2f} % of the diagonal)") for k, r in self.runs.items()]
        rows += [("face", self.surface), ("resolution", mm(self.resolution, 0)), ("converged", self.converged)]
        if self.monte_carlo is not None:
            rows.append(("Monte-Carlo samples", self.monte_carlo.rms.shape[0]))
        return "DesignCheck", rows

    @property
    def converged(self) -> bool:
        """True when every run converged."""
        return all(r.inflation.converged for r in self.runs.values())


def named_face(design, strings: StringSet) -> str:
    """The face Ŝ stands for: the one whose metric Ŝ was relaxed in, else the face opposite the strings.

    A design whose Ŝ took a face's metric (``report.metric["face"]``, airmat.design.face_metric)
    names that face, so the design and the check speak of one surface; otherwise the
    face opposite the larger share of bending (:func:`airmat.design.face_metric.length_keeping_face`:
    each string's |κ| times its span, the string face shortening by about |κ| d per unit
    length).

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
    strings : airmat.inflation.strings.StringSet
        The design's strings (:func:`design_strings`).

    Returns
    -------
    str
        ``"top"`` or ``"bottom"``.
    """
    share = np.abs([s.kappa for s in design.pattern.strings]) * np.linalg.norm(strings.b - strings.a, axis=1)
    return strings_named_face(design.approx.report, share, strings.top)


def check(design, *, resolution: float = 0.020, params: Parameters = Parameters(), envelope: bool = True,
          strict: bool = False, workers: int = 1, scheduler: str | None = None, surface: str = "auto",
          calibrated_map: bool = False, lengths=None, samples: int = 0, seed: int = 0,
          tolerance: float | None = None, known: KnownRun | None = None) -> DesignCheck:
    """Inflate a design at its median string lengths (and at lo95 / hi95) and compare with Ŝ.

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
        In memory or read from its folder.
    resolution : float
        Edge length of the double-layer mesh (m); must resolve the strings
        (at least 4 edges along each).
    params : Parameters
        Pressure and stiffnesses of U_B.
    envelope : bool
        Also run the lo95 and hi95 lengths.
    strict : bool
        Raise ConvergenceError when a run does not converge.
    workers : int
        Local worker processes for the runs (1: one after the other, in this process).
    scheduler : str, optional
        Address of an existing Dask scheduler for the runs (:mod:`airmat.inflation.executor`).
    surface : {"auto", "top", "bottom", "mid"}
        The face compared with Ŝ; ``"auto"``: the named face (:func:`named_face`).
    calibrated_map : bool
        Simulate each real length at the rest length of the calibrated length map
        (:func:`~airmat.check.length_map.length_map` with ``calibrated=True``, built at this
        resolution and the mattress's thickness, cached on disk) instead of l + 2Δ.
    lengths : LengthMap or CalibratedLengthMap, optional
        The map to use (overrides ``calibrated_map``).
    samples : int
        Monte-Carlo samples K of the strings' lengths (:func:`airmat.check.monte_carlo.draw`), inflated
        with the median / lo95 / hi95 runs in one batch; 0: none.
    seed : int
        Seed of the Monte-Carlo samples.
    tolerance : float, optional
        T (m) of the Monte-Carlo's P(RMS <= T).
    known : KnownRun or sequence of KnownRun, optional
        Used as the median run (or a refined design's open-loop equilibrium) instead of
        inflating again when it is that run (:meth:`KnownRun.stands_for`; e.g.
        ``Refinement.known_runs``); otherwise ignored.

    Returns
    -------
    DesignCheck
        Its runs inflated from the flat mattress (and a refined design's ``open_loop``) keep their
        continuation's coarser solutions (``Inflation.levels``; the linear tolerance's validation
        starts its own mesh's run from there).

    Raises
    ------
    airmat.errors.InputError
        A resolution too coarse for the strings or too fine for memory.
    """
    m = design.mattress
    mesh = build_mattress_mesh(m.width, m.height, m.thickness, resolution=resolution)
    which_runs = LENGTH_KEYS if envelope else ("median",)
    check_resolution(design_strings(design), resolution)      # before any specimen runs of a calibrated map
    if lengths is None:
        lengths = length_map(design.calibration, calibrated=calibrated_map, resolution=resolution,
                             thickness=m.thickness, params=params, workers=workers)
    log.debug("string lengths simulated through %s", type(lengths).__name__)
    string_sets = [design_strings(design, which, lengths=lengths) for which in which_runs]
    draws = draw(design, samples, seed, lengths=lengths) if samples > 0 else None
    mc_sets = [replace(string_sets[0], rest=rest) for rest in draws.rest] if draws is not None else []
    to_run = string_sets + mc_sets
    knowns = () if known is None else (known,) if isinstance(known, KnownRun) else tuple(known)

    def known_run(strings, start):
        return next((k for k in knowns if k.stands_for(strings, mesh, params, INFLATE_TOL, start)
                     and (k.inflation.converged or not strict)), None)

    start_set = open_loop_strings(design, lengths=lengths)
    base = None
    if start_set is not None:       # a refined design: from its open-loop equilibrium, as it was refined
        kb = known_run(start_set, None)
        base = kb.inflation if kb is not None else \
            inflate(mesh, start_set if len(start_set) else None, params=params, strict=strict, keep_levels=True)
        log.info("open-loop lengths: %d Newton iterations in %.1f s%s; the runs start from there", base.n_iter,
                 base.seconds, " (known)" if kb is not None else "")
    reuse = known_run(string_sets[0], start_set)
    if reuse is not None:
        log.debug("the median run is the known inflation (%d Newton iterations): not run again", reuse.inflation.n_iter)
        to_run = to_run[1:]
    inflations = inflate_many(mesh, [s if len(s) else None for s in to_run], params=params,
                              strict=strict, workers=workers, scheduler=scheduler, start=base, keep_levels=True)
    if reuse is not None:
        inflations = [replace(reuse.inflation, mesh=mesh, levels=())] + inflations
    inflations, mc_runs = inflations[:len(which_runs)], inflations[len(which_runs):]
    a, b = string_sets[0].a, string_sets[0].b
    polylines = [s.dash.polyline for s in design.pattern.strings]
    named = named_face(design, string_sets[0]) if surface == "auto" else surface
    free = np.where(string_sets[0].top, "bottom", "top")
    to_target = _target_distance(design)
    runs = {}
    for which, inf in zip(which_runs, inflations):
        if not inf.converged:
            log.warning("inflation with the %s string lengths did not converge: %s", which, inf.message)
        devs = {face: deviation(inf, design.approx.xyz, design.approx.uv, face) for face in SURFACES}
        dev = devs[named]
        kap = realized_curvature(inf, a, b, polylines, named)
        kap_free = realized_curvature(inf, a, b, polylines, free)
        log.info("%s lengths: %d Newton iterations in %.1f s; deviation of the %s face RMS %.1f mm, max %.1f mm "
                 "(mid-surface RMS %.1f mm)", which, inf.n_iter, inf.seconds, named, dev.rms * 1e3,
                 dev.max * 1e3, devs["mid"].rms * 1e3)
        runs[which] = CheckRun(which, inf, dev, kap, devs, kap_free, to_target(dev.aligned))
    mc = None
    if draws is not None:
        devs = [deviation(inf, design.approx.xyz, design.approx.uv, named) for inf in mc_runs]
        if not all(inf.converged for inf in mc_runs):
            log.warning("%d of %d Monte-Carlo runs did not converge", sum(not i.converged for i in mc_runs), samples)
        mc = summarize(draws, devs, tolerance=tolerance, converged=[inf.converged for inf in mc_runs],
                       seconds=sum(inf.seconds for inf in mc_runs))
        st = mc.stats()
        log.info("Monte-Carlo, %d samples: RMS median %.1f mm, 95th percentile %.1f mm", samples,
                 st["rms_median"] * 1e3, st["rms_p95"] * 1e3)
    return DesignCheck(design=design, resolution=resolution, runs=runs, surface=named, lengths=lengths,
                       monte_carlo=mc, open_loop=None if base is None else replace(base, mesh=mesh),
                       approx_to_target=to_target(design.approx.xyz))


def _target_distance(design):
    """points -> their TargetDistance to the design's target S (one projector), or to None without S."""
    target = design.approx.target
    if target is None:
        return lambda points: None
    from airmat.design.closest_point import MeshProjector

    projector = MeshProjector(target.vertices, target.faces)
    diag = float(np.linalg.norm(np.ptp(design.approx.xyz, axis=0)))
    return lambda points: distance_to_target(points, target, diagonal=diag, projector=projector)


def monte_carlo(design, samples: int = 64, *, seed: int = 0, tolerance: float | None = None,
                resolution: float = 0.020, **options):
    """The tolerance of a design as a distribution: ``samples`` inflations at sampled string lengths.

    Each sample draws Δ, d from the design's calibration posterior and a scatter per
    string (:func:`airmat.check.monte_carlo.draw`), inflates the mattress at those
    lengths and measures the named face against Ŝ.

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
    samples : int
        Number of Monte-Carlo samples K (at least 1).
    seed : int
        Seed of the sampled lengths.
    tolerance : float, optional
        T (m): the result gives P(RMS <= T).
    resolution : float
        Edge length of the double-layer mesh (m).
    **options
        Passed to :func:`check` (``workers``, ``scheduler``, ``known``, ``params``, ...).

    Returns
    -------
    airmat.check.monte_carlo.MonteCarloResult
        RMS deviation per sample (m), per-vertex quantiles, convergence per sample.
    """
    if not (isinstance(samples, (int, np.integer)) and samples >= 1):
        raise InputError(f"monte_carlo needs at least one sample, got {samples!r}")
    options.setdefault("envelope", False)
    return check(design, resolution=resolution, samples=int(samples), seed=seed, tolerance=tolerance,
                 **options).monte_carlo
