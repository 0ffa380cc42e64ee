"""The updated posterior as a calibration: what ``airmat calibrate`` writes, learned from a built mattress.

:func:`updated_calibration` turns an :class:`~airmat.asbuilt.update.Update` into a
:class:`~airmat.calib.calibrate.Calibration`, so that
:func:`airmat.calib.calibration_io.write_calibration` writes it (calibration.json,
posterior.npz, specimens.csv) and ``airmat design --calibration DIR`` designs the next
shape with it (:func:`airmat.design.calibration_source.load_calibration`). The posterior
samples are the update's seeded Gaussian draws of (Δ, d) with σ carried over; the curve
κ₁(l/L) and the specimens' model curvatures are recomputed from them. The cylinder
specimens and the manifest are the base calibration's (the posterior still rests on
them); the provenance (the design and the scans it learned from, the method) is the
posterior's message, written as ``diagnostics.message``. SI units (m, 1/m).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from airmat.calib.calibrate import Calibration
from airmat.calib.curve import kappa_curve
from airmat.calib.model import kappa1
from airmat.calib.posterior import ParamSummary, Posterior
from airmat.errors import InputError

__all__ = ["updated_calibration", "provenance"]


def provenance(upd, design, scans=()) -> str:
    """One line on where an updated calibration comes from: method, design, scans, convergence."""
    where = design.source or design.name
    scanned = ", ".join(str(s) for s in scans) if scans else "a registered scan"
    return (f"as-built update (airmat.asbuilt.update, Laplace): the calibration of design {where} "
            f"({design.calibration.source}) updated with {scanned} of its built {upd.surface} face; "
            f"{upd.iterations} linearisations, {upd.message}; delta and d drawn as a Gaussian "
            f"(seed {upd.seed}), sigma carried over")


def _base(design, base):
    if base is not None:
        return base
    source = Path(str(design.calibration.source))
    if design.calibration.uncalibrated or not (source / "calibration.json").is_file():
        raise InputError(f"the design's calibration ({design.calibration.source}) is not a calibration folder: "
                         "give the cylinder calibration it was made from (base=read_calibration(DIR)); a "
                         "calibration folder keeps the specimens its posterior rests on")
    from airmat.calib.calibration_io import read_calibration

    return read_calibration(source)


def updated_calibration(upd, design, *, base=None, scans=(), n_grid: int | None = None) -> Calibration:
    """The update's posterior as a :class:`~airmat.calib.calibrate.Calibration` (SI units).

    Parameters
    ----------
    upd : airmat.asbuilt.update.Update
    design : airmat.design.pipeline.DesignResult
        The design the scanned mattress was built from.
    base : airmat.calib.calibrate.Calibration, optional
        The cylinder calibration the design was made from; default read from the design's
        calibration folder (``design.calibration.source``).
    scans : sequence of str
        The scan files the update learned from, for the provenance.
    n_grid : int, optional
        Grid points of the curve; default the base curve's (101 without one).

    Returns
    -------
    Calibration
        Its posterior's samples are ``upd.samples``; its message the :func:`provenance`.

    Raises
    ------
    airmat.errors.InputError
        No base calibration: the design used the paper's values, or its folder is gone.
    """
    base = _base(design, base)
    samples = np.asarray(upd.samples, float)
    if samples.ndim != 2 or samples.shape[1] != 3:
        raise InputError(f"update samples: expected shape (n, 3), got {samples.shape}")
    diff = samples[:, :2] - upd.mean
    inv = np.linalg.pinv(upd.covariance)
    log_prob = -0.5 * np.einsum("ni,ij,nj->n", diff, inv, diff)
    p0 = base.posterior
    post = Posterior(samples=samples, log_prob=log_prob, delta=ParamSummary.of(samples[:, 0]),
                     d=ParamSummary.of(samples[:, 1]), sigma=ParamSummary.of(samples[:, 2]),
                     start=np.array([upd.mean[0], upd.mean[1], float(np.median(samples[:, 2]))]),
                     # no chain: zero steps, walkers and autocorrelation (not NaN: the JSON writes NaN as
                     # null, which the reader refuses)
                     tau=np.zeros(3), acceptance_fraction=0.0, n_steps=0, n_walkers=0, burn=0,
                     thin=1, converged=bool(upd.converged), n_iter=int(upd.iterations),
                     residual=float(upd.residual), message=provenance(upd, design, scans), priors=p0.priors)
    grid = base.curve.l_over_L.size if n_grid is None and base.curve.l_over_L.size >= 2 else (n_grid or 101)
    curve = kappa_curve(samples, base.curve.L, n_grid=int(grid), seed=upd.seed)
    man = base.manifest
    model = (np.median(kappa1(man.l[None, :], man.L[None, :], samples[:, :1], samples[:, 1:2]), axis=0)
             if len(man) else np.zeros(0))
    return Calibration(manifest=man, specimens=base.specimens, posterior=post, curve=curve, kappa_model=model,
                       seed=int(upd.seed), timings={"update": round(float(upd.seconds), 3)})
