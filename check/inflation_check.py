"""The inflation check of a design: inflate at the median string lengths and at both tolerance ends.

``check_design`` reads nothing and writes nothing: give it a
:class:`~check.design_folder.DesignFolder`; it builds the
double-layer mesh, inflates it three times (strings at their median,
lo95 and hi95 lengths, each simulated at l + 2Δ) and compares each result
with Ŝ. SI units.

The three runs are independent, so ``workers > 1`` runs them in that many
processes (:func:`~inflation.simulate.inflate_many`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from check.compare import Deviation, deviation, realized_curvature
from check.design_folder import LENGTH_KEYS, DesignFolder
from inflation.mesh import build_mattress_mesh
from inflation.model import Parameters
from inflation.simulate import Inflation, inflate_many
from inflation.strings import check_resolution

__all__ = ["CheckRun", "DesignCheck", "check_design"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class CheckRun:
    """One inflation of the design and how far it lands from Ŝ."""

    which: str
    inflation: Inflation
    deviation: Deviation
    kappa_realized: np.ndarray


@dataclass(frozen=True)
class DesignCheck:
    """The median run and the tolerance envelope (``runs['median' | 'lo95' | 'hi95']``)."""

    design: DesignFolder
    resolution: float
    runs: dict

    @property
    def converged(self) -> bool:
        return all(r.inflation.converged for r in self.runs.values())


def check_design(design: DesignFolder, *, resolution: float = 0.025, params: Parameters = Parameters(),
                 envelope: bool = True, strict: bool = False, workers: int = 1) -> DesignCheck:
    """Inflate a design at its median string lengths (and at lo95 / hi95) and compare with Ŝ.

    Parameters
    ----------
    design : DesignFolder
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
        Processes for the runs (1: one after the other, in this process).

    Raises
    ------
    airmat.errors.InputError
        A resolution too coarse for the strings or too fine for memory.
    """
    mesh = build_mattress_mesh(design.width, design.height, design.thickness, resolution=resolution)
    check_resolution(design.strings(), resolution)
    which_runs = LENGTH_KEYS if envelope else ("median",)
    string_sets = [design.strings(which) for which in which_runs]
    inflations = inflate_many(mesh, [s if len(s) else None for s in string_sets], params=params,
                              strict=strict, workers=workers)
    runs = {}
    for which, inf in zip(which_runs, inflations):
        if not inf.converged:
            log.warning("inflation with the %s string lengths did not converge: %s", which, inf.message)
        dev = deviation(inf, design.approx_xyz, design.approx_uv)
        kap = realized_curvature(inf, design.a, design.b, design.polylines)
        log.info("%s lengths: %d Newton iterations in %.1f s; deviation RMS %.1f mm, max %.1f mm",
                 which, inf.n_iter, inf.seconds, dev.rms * 1e3, dev.max * 1e3)
        runs[which] = CheckRun(which, inf, dev, kap)
    return DesignCheck(design=design, resolution=resolution, runs=runs)
