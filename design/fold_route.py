"""The fold route: when Ŝ strains the mattress more than it can, let it gather into drape-like folds.

A doubly curved target S with K > 0 (a dome) cannot be covered by the flat mattress without
contracting its rim: pulled onto S, Ŝ spreads that strain over σ = 0.86 … 1.25, which the
membrane cannot make. The paper (§4, the dome of Table 1) makes such a shape constructible "by
introducing drape-like folds to reduce the Gaussian curvature", found by hand through the
weights of U_A. This module searches those weights: it stiffens the edge lengths (k_A1, against
the closest-point pull k_A2) by growing factors until the relaxation, keeping the mattress's
lengths, gathers the excess into a few folds and σ falls inside the fold band (the paper's dome:
σ min 0.934). Ŝ then leaves S by the folds' height: that price, Ŝ's distance to S, is reported for
every trial. The route runs only where the plain Ŝ contracts edges below the band (folds gather
excess length); a Ŝ that only stretches (a saddle whose rim would have to grow) keeps its verdict.

Along a fold |κ| exceeds what a string makes (the paper's dome: 35 1/m); those vertices are the
folds, where the mattress buckles by itself, and the constructibility verdict counts them as such
(:func:`airmat.design.constructibility.constructibility`, ``folds``) when they cover a small share
of Ω. Units: m and 1/m.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from airmat.design.closest_point import MeshProjector
from airmat.forked import ForkedMap, can_fork
from airmat.progress import progress
from airmat.geometry.topology import boundary_vertex_mask, flat_vertex_areas

__all__ = ["FOLD_SIGMA_BAND", "FOLD_RATIOS", "FoldTrial", "FoldRoute", "fold_route", "start_trials",
           "fold_vertices", "needs_folds", "folds_likely", "total_curvature", "cap_curvature"]

log = logging.getLogger(__name__)

#: σ band a folded Ŝ must keep to (the paper's built dome: σ min 0.934, avg 0.997; Table 1)
FOLD_SIGMA_BAND = (0.93, 1.07)
#: factors on k_A1 tried in turn (the relaxation's k_A2 and k_A3 kept)
FOLD_RATIOS = (3.0, 10.0, 30.0, 100.0)


@dataclass(frozen=True)
class FoldTrial:
    """One relaxation of the search.

    Attributes
    ----------
    ratio : float
        Factor on the design's k_A1 (1: the plain Ŝ).
    k_a1 : float
    sigma_min, sigma_max : float
        Edge length ratio Ŝ / Ω (in the named face's metric where it has one).
    to_target_rms, to_target_max : float
        Ŝ's distance to S (m).
    fold_share : float
        Share of Ω's area whose |κ| exceeds the reachable curvature.
    within_band : bool
        σ inside the fold band.
    converged : bool
        The relaxation's own verdict.
    """

    ratio: float
    k_a1: float
    sigma_min: float
    sigma_max: float
    to_target_rms: float
    to_target_max: float
    fold_share: float
    within_band: bool
    converged: bool

    def excursion(self, band) -> float:
        """How far σ leaves ``band`` (0 inside)."""
        lo, hi = band
        return max(lo - self.sigma_min, self.sigma_max - hi, 0.0)

    def summary_mm(self) -> dict:
        """The trial in file units (mm)."""
        return {"ratio": self.ratio, "k_a1": self.k_a1, "sigma_min": round(self.sigma_min, 5),
                "sigma_max": round(self.sigma_max, 5), "to_target_rms_mm": round(self.to_target_rms * 1e3, 3),
                "to_target_max_mm": round(self.to_target_max * 1e3, 3), "fold_share": round(self.fold_share, 4),
                "within_band": bool(self.within_band), "converged": bool(self.converged)}

    @classmethod
    def from_summary_mm(cls, d: dict) -> "FoldTrial":
        """The trial from its file form (:meth:`summary_mm`)."""
        return cls(ratio=float(d["ratio"]), k_a1=float(d["k_a1"]), sigma_min=float(d["sigma_min"]),
                   sigma_max=float(d["sigma_max"]), to_target_rms=float(d["to_target_rms_mm"]) / 1e3,
                   to_target_max=float(d["to_target_max_mm"]) / 1e3, fold_share=float(d["fold_share"]),
                   within_band=bool(d["within_band"]), converged=bool(d["converged"]))


@dataclass(frozen=True)
class FoldRoute:
    """What the fold route tried and chose.

    Attributes
    ----------
    trials : tuple of FoldTrial
        The plain Ŝ first, then each stiffened relaxation, in the order tried.
    chosen : int
        Index into ``trials`` of the Ŝ the design uses: the first within the band, else the one
        whose σ leaves it least.
    sigma_band : (float, float)
    found : bool
        A trial within the band was found.
    message : str
        One sentence for the user: what was chosen and its price, or why none was found.
    """

    trials: tuple
    chosen: int
    sigma_band: tuple
    found: bool
    message: str

    def summary_mm(self) -> dict:
        """design.json's ``fold_route`` block (mm)."""
        return {"found": bool(self.found), "chosen": int(self.chosen),
                "sigma_band": [float(b) for b in self.sigma_band], "message": self.message,
                "trials": [t.summary_mm() for t in self.trials]}

    @classmethod
    def from_summary_mm(cls, d: dict) -> "FoldRoute":
        """The route from design.json's ``fold_route`` block (:meth:`summary_mm`)."""
        return cls(trials=tuple(FoldTrial.from_summary_mm(t) for t in d["trials"]), chosen=int(d["chosen"]),
                   sigma_band=tuple(float(b) for b in d["sigma_band"]), found=bool(d["found"]),
                   message=str(d["message"]))

    @property
    def trial(self) -> FoldTrial:
        """The chosen trial."""
        return self.trials[self.chosen]


def needs_folds(report) -> bool:
    """Ŝ contracts edges below the σ band: material a fold could gather (the case the fold route is for).

    A Ŝ that only stretches beyond the band (a saddle: its rim would have to grow) or only exceeds
    the reachable curvature is not: folds absorb excess length, they do not supply it.
    """
    return report is not None and report.sigma["min"] < report.sigma_band[0]


def total_curvature(vertices, faces) -> float:
    """∫K dA over a triangle mesh's interior: the sum of its interior vertices' angle defects
    (trimesh's ``vertex_defects``; dimensionless). The rim's own ring is left out, so an open mesh
    reads a little low: a spherical cap of 60° (∫K = π) meshed at 1/50 of its radius reads 3.0.

    Examples
    --------
    >>> import trimesh
    >>> sphere = trimesh.creation.icosphere(subdivisions=5)
    >>> cap = trimesh.Trimesh(sphere.vertices, sphere.faces[sphere.triangles_center[:, 2] > 0.5])
    >>> round(total_curvature(cap.vertices, cap.faces), 1)
    3.0
    """
    import trimesh

    vertices, faces = np.asarray(vertices, float), np.asarray(faces)
    defects = trimesh.Trimesh(vertices, faces, process=False).vertex_defects
    used = np.zeros(len(vertices), bool)
    used[faces.ravel()] = True
    return float(defects[used & ~boundary_vertex_mask(faces, len(vertices))].sum())


def cap_curvature(sigma: float) -> float:
    """The total curvature 2π (1 − cos θ) of the spherical cap whose rim a flat disc reaches only by
    contracting it to ``sigma`` (sin θ / θ = σ: the disc keeps its radius along the sphere).

    Examples
    --------
    >>> round(cap_curvature(0.93), 2)
    1.3
    """
    from scipy.optimize import brentq

    theta = brentq(lambda t: np.sin(t) / t - sigma, 1e-6, np.pi)
    return float(2.0 * np.pi * (1.0 - np.cos(theta)))


def folds_likely(target, sigma_band=FOLD_SIGMA_BAND) -> bool:
    """Whether S holds more Gaussian curvature than a disc reaches within the band: more than the
    spherical cap whose rim contracts to the band's lower end (:func:`cap_curvature`, 1.30 at 0.93).

    A forecast, for scheduling only (:func:`start_trials`): the fold route itself runs where the plain
    Ŝ contracts (:func:`needs_folds`). On the presets and the zoo (``airmat.synthetic.zoo``) it holds for
    the three domes the fold route takes (the dome preset 7.97, dome-r450 4.25, dome-r1000-large 4.95)
    and for nothing else (vault2 0.94, vault1 0.90, the shallow dome 0.12; saddles are negative).
    """
    return total_curvature(target.vertices, target.faces) > cap_curvature(sigma_band[0])


def start_trials(relax_with, *, k_a1: float, ratios=FOLD_RATIOS, workers: int = 1):
    """The fold route's first ``workers`` relaxations started now on forked processes, beside the plain one
    this process is about to run (:class:`airmat.forked.ForkedMap`); None where nothing would fork (one
    worker, no fork). :func:`fold_route` takes them (``started``) where the plain Ŝ needs folds; else they
    are given up (``cancel()``). The same relaxations as the route would start after the plain one."""
    step = max(1, int(workers))
    if step < 2 or not can_fork():
        return None
    return _relax_batch(relax_with, k_a1, list(ratios)[:step])


def _relax_batch(relax_with, k_a1: float, batch) -> ForkedMap:
    """The relaxations with k_A1 × each factor of ``batch``, one forked process each (one at a time here when
    the batch has one factor or nothing forks)."""
    return ForkedMap(relax_with, [k_a1 * r for r in batch], len(batch))


def fold_vertices(kappa, kappa_max: float) -> np.ndarray:
    """Vertices where |κ| exceeds the reachable curvature, shape (n,) bool: the folds of a folded Ŝ."""
    return np.abs(np.asarray(kappa)).max(axis=1) > kappa_max


def _trial(approx, ratio, k_a1, band, projector) -> FoldTrial:
    rep = approx.report
    dist = projector.closest(approx.xyz).distance
    folds = fold_vertices(approx.curvature.kappa, rep.kappa_max)
    area = flat_vertex_areas(approx.uv, approx.faces)
    lo, hi = band
    return FoldTrial(ratio=float(ratio), k_a1=float(k_a1), sigma_min=float(rep.sigma["min"]),
                     sigma_max=float(rep.sigma["max"]), to_target_rms=float(np.sqrt(np.mean(dist ** 2))),
                     to_target_max=float(dist.max()), fold_share=float(area @ folds / area.sum()),
                     within_band=bool(lo <= rep.sigma["min"] and rep.sigma["max"] <= hi),
                     converged=bool(approx.relax.converged))


def fold_route(approx, relax_with, *, k_a1: float, ratios=FOLD_RATIOS, sigma_band=FOLD_SIGMA_BAND,
               workers: int = 1, started=None):
    """Search the U_A weights for a folded Ŝ whose σ keeps to ``sigma_band``.

    Parameters
    ----------
    approx : airmat.design.surface.ApproxSurface
        The plain Ŝ (it contracts edges below the σ band).
    relax_with : callable
        ``relax_with(k_a1) -> ApproxSurface``: the same relaxation with another k_A1, its verdict
        judged by ``sigma_band`` and counting the curvature beyond reach as folds
        (``approximate_surface(..., folds=True, sigma_band=sigma_band)``).
    k_a1 : float
        The plain Ŝ's k_A1.
    ratios : sequence of float
        Factors on ``k_a1`` tried in turn; the search stops at the first Ŝ within the band.
    sigma_band : (float, float)
    workers : int
        Trials relaxed at a time, the next ``workers`` factors each on a forked process
        (:class:`airmat.forked.ForkedMap`, Linux); the search still stops at the first factor within
        the band, so the answer is the one of one trial at a time (1: one at a time, in this process).
    started : airmat.forked.ForkedMap, optional
        The first ``workers`` relaxations, already started beside the plain one (:func:`start_trials`
        with the same ``relax_with``, ``k_a1``, ``ratios`` and ``workers``).

    Returns
    -------
    approx : ApproxSurface
        The chosen Ŝ: the first trial within the band, else the one whose σ leaves it least (the
        plain one, as given, when none did better).
    route : FoldRoute
    """
    target = approx.target
    projector = MeshProjector(target.vertices, target.faces)
    surfaces = [approx]
    trials = [_trial(approx, 1.0, k_a1, sigma_band, projector)]
    ratios, step = list(ratios), max(1, int(workers))
    for first in range(0, len(ratios), step):
        batch = ratios[first:first + step]
        log.info("fold route: relaxing with k_A1 × %s", ", ".join(f"{r:g}" for r in batch))
        runs = started if first == 0 and started is not None else _relax_batch(relax_with, k_a1, batch)
        if runs.forked:         # the relaxations' own bars are off in the forked processes: count the trials
            with progress(total=len(batch), desc=f"fold route (k_A1 × {', '.join(f'{r:g}' for r in batch)})",
                          unit="trial") as bar:
                relaxed = runs.results(on_result=bar.update)
        else:
            relaxed = runs.results()
        for ratio, surface in zip(batch, relaxed):
            surfaces.append(surface)
            trials.append(_trial(surface, ratio, k_a1 * ratio, sigma_band, projector))
            if trials[-1].within_band:
                break
        if trials[-1].within_band:
            break
    found = trials[-1].within_band
    chosen = len(trials) - 1 if found else int(np.argmin([t.excursion(sigma_band) for t in trials]))
    t = trials[chosen]
    lo, hi = sigma_band
    if found:
        message = (f"with k_A1 × {t.ratio:g} Ŝ keeps σ within [{lo:g}, {hi:g}] ({t.sigma_min:.3f}–{t.sigma_max:.3f}), "
                   f"folds on {100 * t.fold_share:.1f} % of Ω; the price: Ŝ lies {1e3 * t.to_target_rms:.1f} mm RMS "
                   f"(max {1e3 * t.to_target_max:.1f}) from S, against {1e3 * trials[0].to_target_rms:.1f} mm "
                   f"with the plain weights")
    else:
        message = (f"no constructible Ŝ: with k_A1 up to × {max(ratios):g} σ still leaves [{lo:g}, {hi:g}]; the "
                   f"best found (k_A1 × {t.ratio:g}) has σ {t.sigma_min:.3f}–{t.sigma_max:.3f}, "
                   f"{1e3 * t.to_target_rms:.1f} mm RMS from S: the target asks more of the mattress than it can "
                   f"gather into folds")
    log.info("fold route: %s", message)
    return surfaces[chosen], FoldRoute(trials=tuple(trials), chosen=chosen, sigma_band=tuple(map(float, sigma_band)),
                                     found=bool(found), message=message)
