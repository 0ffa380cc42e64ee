"""``airmat correct``: a scan of the built mattress -> registration, deviation maps, update, corrected strings.

The chain (each step its own module):

1. the design's prediction: its check's median run (:func:`airmat.check.inflation_check.check`), moved
   into Ŝ's frame by the check's alignment; the face a scanner above it sees
   (:func:`airmat.asbuilt.true_world.upper_face`) is the reference;
2. the scan registered onto that face in any frame and unit, floor and clutter removed
   (:func:`airmat.asbuilt.registration.register`), or, when that face refuses it, onto the check's
   lo95 or hi95 prediction (a world beyond the calibration lies nearer those); the points that lie on
   the face (within ``max_distance`` of it, inside its outline) are the data;
3. two deviation maps of those points (:func:`airmat.asbuilt.deviation_map.deviation_map`): against
   Ŝ (what the user wanted) and against the prediction (what the model expected);
4. the calibration's (Δ, d) and every string's length error updated with them (Laplace,
   :func:`airmat.asbuilt.update.update`), on the scanned face, alternating with the registration: the
   scan registered again onto the updated prediction from the pose it has, and the update carried on
   from where it stopped, until the pose holds (:mod:`airmat.asbuilt.alternation`);
5. corrected lengths, the re-tie list and the corrected design (:func:`airmat.asbuilt.correction.correct`);
6. the update as a calibration (:func:`airmat.asbuilt.updated_calibration.updated_calibration`), when
   the design was made from a calibration folder (one made with the paper's values has no
   specimens to carry over: then none, and a note says so).

SI units (m, 1/m) inside; :mod:`airmat.asbuilt.correct_io` writes the folder in mm.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from airmat.asbuilt.alternation import (FIRST_RELINEARISATIONS, MAX_DISTANCE, POSE_TOL, REGISTRATION, REREGISTRATIONS,
                                        ROUND_POINTS, alternate, choose_pose, on_face, round_subset, scanned_face)
from airmat.constants import CUT_TOLERANCE
from airmat.errors import InputError
from airmat.inflation.model import Parameters
from airmat.summary import Summarized, mm

__all__ = ["AsBuilt", "correct", "scanned_face", "scanned_target", "MAX_DISTANCE", "REGISTRATION", "REREGISTRATIONS", "POSE_TOL",
           "FIRST_RELINEARISATIONS", "ROUND_POINTS", "round_subset"]

log = logging.getLogger(__name__)


@dataclass(frozen=True, repr=False)
class AsBuilt(Summarized):
    """What a scan of the built mattress says, and what to do about it.

    Attributes
    ----------
    design : airmat.design.pipeline.DesignResult
        The design the mattress was built from.
    scan : str
        The scan's name (its file).
    surface : str
        The scanned face (``"top"`` or ``"bottom"``: the one looking up).
    reference_xyz : ndarray of shape (n, 3)
        The predicted mattress in Ŝ's frame (m); ``reference_faces`` index it.
    reference_faces : ndarray of shape (t, 3)
        The scanned face's triangles.
    registration : airmat.asbuilt.registration.Registration
    points : ndarray of shape (M, 3)
        The scan points on the face, in Ŝ's frame (m).
    to_target : airmat.asbuilt.deviation_map.DeviationMap
        The points against the scanned face's target (:func:`scanned_target`: Ŝ itself when the scanned
        face is the named one).
    to_prediction : airmat.asbuilt.deviation_map.DeviationMap
        The points against the predicted face.
    update : airmat.asbuilt.update.Update
    correction : airmat.asbuilt.correction.Correction
    calibration : airmat.calib.calibrate.Calibration or None
        The updated calibration; None when the design has no calibration folder to extend.
    notes : tuple of str
    seconds : float
    """

    design: object
    scan: str
    surface: str
    reference_xyz: np.ndarray
    reference_faces: np.ndarray
    registration: object
    points: np.ndarray
    to_target: object
    to_prediction: object
    update: object
    correction: object
    calibration: object
    notes: tuple = ()
    seconds: float = 0.0

    def _summary(self):
        c = self.correction
        after = c.rms_linear if c.rms_verified is None else c.rms_verified
        return "AsBuilt", [("scan", self.scan), ("registration", f"{mm(self.registration.rms, 2)} RMS, "
                                                               f"{100 * self.registration.inlier_share:.0f} % inliers"),
                           ("to Ŝ", mm(self.to_target.rms)), ("to prediction", mm(self.to_prediction.rms)),
                           ("re-tie", repr(c.plan)[len("<RetiePlan: "):-1]),
                           ("after correction", f"{mm(after, 2)} ({100 * after / c.diagonal:.2f} % of the diagonal)")]


def scanned_target(design, named: str, scanned: str) -> np.ndarray:
    """Where Ŝ puts the scanned face, (N, 3) at Ŝ's vertices (m).

    Ŝ is the named face's target (:func:`airmat.check.inflation_check.named_face`). A scanner sees
    the face looking up; when that is the other face, its target lies the mattress's thickness
    above Ŝ, along Ŝ's normals turned up (the faces of a drop-stitch mattress stay that far apart).
    """
    a = design.approx
    if scanned == named:
        return a.xyz
    from airmat.design.curvature import vertex_normals

    n = vertex_normals(a.xyz, a.faces)
    n = n if n[:, 2].sum() >= 0 else -n
    return a.xyz + design.mattress.thickness * n


def _register_on_envelope(design, check, raw, refusal, *, seed, units, name, params, clouds=None):
    """The first registration onto the check's lo95 or hi95 prediction when the median's refused the scan:
    (Registration, "lo95" or "hi95", (vertices, triangles) of that face), the one with the larger share of
    inliers; ``refusal`` raised again when both refuse it too.

    A mattress built in a world beyond the calibration's 95 % intervals can lie farther from the median
    prediction than a scan of another design does (refined vault1 in ``bench/bench_correct.py``'s world,
    24 mm RMS from Ŝ: 46 % of the median prediction covered; onto hi95: 8.4 mm RMS, 98 % inliers); the
    prediction at the interval's end lies nearer. A scan that fits neither is refused as before, and the
    registrations onto the updated prediction refuse one the learned shape does not fit.
    """
    from airmat.asbuilt.registration import register
    from airmat.check.inflation_check import check as run_check

    env = check if {"lo95", "hi95"} <= set(check.runs) else \
        run_check(design, resolution=check.resolution, params=params, envelope=True, surface=check.surface,
                  lengths=check.lengths)
    best = None
    for which in ("hi95", "lo95"):
        run = env.runs[which]
        xyz, _, faces = scanned_face(run)
        try:
            reg = register(raw, xyz, faces, seed=seed, units=units, name=name, clouds=clouds, **REGISTRATION)
        except InputError as err:
            if "inlier_share" not in err.data:
                raise
            continue
        if best is None or reg.inlier_share > best[0].inlier_share:
            best = (reg, which, (xyz, faces))
    if best is None:
        raise refusal
    log.info("as-built: the scan registered onto the %s prediction (%.1f mm RMS, %.0f %% inliers)", best[1],
             1e3 * best[0].rms, 100 * best[0].inlier_share)
    return best


def _scan_points(scan, scan_units, seed) -> tuple:
    """(points (N, 3) in the file's unit read as given, name) of a path or an array (m)."""
    if isinstance(scan, (str, os.PathLike)):
        from airmat.calib.scan_io import read_scan

        s = read_scan(scan, units=scan_units, seed=seed, specimen=False)
        return s.points + s.offset, Path(scan).name
    pts = np.asarray(scan, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"scan points must have shape (N, 3), got {pts.shape}")
    return pts, "the scan"


def correct(design, scan, *, check=None, resolution: float = 0.020, params: Parameters = Parameters(),
            scan_units: str | None = None, units: str = "auto", cut_tolerance: float = 0.003,
            keep_tolerance: float = CUT_TOLERANCE, max_relinearisations: int | None = None,
            base_calibration=None, seed: int = 0, verify: bool = True) -> AsBuilt:
    """Register a scan of the built mattress, learn from it and correct the strings.

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult or path
        The design the mattress was built from (or its folder).
    scan : path or ndarray of shape (N, 3)
        A scan file any :func:`airmat.calib.scan_io.read_scan` reads, or its points (m), in any
        frame, with floor and clutter.
    check : airmat.check.inflation_check.DesignCheck, optional
        The design's check (its median run is the prediction); default one made here.
    resolution : float
        Mesh edge of the inflations (m).
    params : Parameters
    scan_units : str, optional
        The scan file's unit (``read_scan``'s ``units``); default its format's.
    units : {"auto", "same", "m-as-mm"}
        Unit detection of the registration (``"auto"``: from the extents).
    cut_tolerance : float
        t (m) of the strings' cut and tie errors (the prior of each string's error).
    keep_tolerance : float
        A string whose length needs to change by at most this is kept (m).
    max_relinearisations : int, optional
        Of the update once the pose holds; default :data:`airmat.asbuilt.update.MAX_RELINEARISATIONS` (each
        one inflation: the face is far from linear in the rest lengths, and fewer leave the update short
        of converged). Before, each round of the alternation with the registration takes at most
        :data:`FIRST_RELINEARISATIONS`.
    base_calibration : airmat.calib.calibrate.Calibration, optional
        The cylinder calibration the design was made from; default read from its folder.
    seed : int
        Seed of the scan's sampling, the registration and the update's draws.
    verify : bool
        Inflate the corrected lengths once in the learned world and report the result.

    Returns
    -------
    AsBuilt

    Raises
    ------
    airmat.errors.InputError
        A scan that is not this design (too few points on the predicted shape), unreadable input.
    """
    from airmat.asbuilt.correction import correct as correct_lengths
    from airmat.asbuilt.deviation_map import deviation_map
    from airmat.asbuilt.registration import register
    from airmat.check.inflation_check import check as run_check
    from airmat.design.design_io import read_design

    started = time.perf_counter()
    if isinstance(design, (str, os.PathLike)):
        design = read_design(design)
    raw, name = _scan_points(scan, scan_units, seed)
    if check is None:
        check = run_check(design, resolution=resolution, params=params, envelope=False)
    med = check.runs["median"]
    xyz, surface, triangles = scanned_face(med)
    notes = []
    target = scanned_target(design, check.surface, surface)
    if surface != check.surface:
        notes.append(f"the scanner sees the {surface} face, Ŝ is the {check.surface} face's target: the scan is "
                     f"compared with Ŝ moved the mattress's thickness up, and the correction lands the {surface} "
                     "face there")
    reference = (xyz, triangles)                 # the face the first registration fits
    clouds = {}                                  # the scan reduced to voxels, once for every registration
    try:
        reg = register(raw, xyz, triangles, seed=seed, units=units, name=name, clouds=clouds, **REGISTRATION)
    except InputError as err:
        if "inlier_share" not in err.data:       # not a mismatch of shapes (a unit, a bad array): as it is
            raise
        reg, which, reference = _register_on_envelope(design, check, raw, err, seed=seed, units=units, name=name,
                                                      params=params, clouds=clouds)
        notes.append(f"the scan did not fit the design's median prediction ({err.message}); it was registered "
                     f"first onto its {which} prediction, then onto what the update learned")
    if reg.n_equivalent > 1:
        notes.append(f"the shape fits {reg.n_equivalent} poses of the scan about as well (a symmetric shape): "
                     "the best one is used; check the deviation map's orientation")
    # the update and the correction work on the scanned face, against its target
    seen = design if target is design.approx.xyz else \
        dataclasses.replace(design, approx=dataclasses.replace(design.approx, xyz=target))
    scanned = dataclasses.replace(check, surface=surface)
    from airmat.asbuilt.update import MAX_RELINEARISATIONS

    relin = MAX_RELINEARISATIONS if max_relinearisations is None else max_relinearisations
    kw = dict(design=seen, raw=raw, name=name, xyz=xyz, triangles=triangles, check=scanned, resolution=resolution,
              params=params, cut_tolerance=cut_tolerance, seed=seed, relin=relin, clouds=clouds,
              subset=round_subset(len(raw), seed))
    first = None
    if reg.alternatives and relin > 0:
        reg, first, note = choose_pose(reg, reference, **kw)
        if note:
            notes.append(note)
    found = alternate(reg, first=first, **kw)
    upd, reg = found.last.update, found.registration
    pts, to_pred, _ = on_face(reg.apply(raw), xyz, triangles, seed)     # every scan point, for the maps
    if found.updates > 1:
        head = f"converged after {found.linearisations} linearisations" if upd.converged else upd.message
        upd = dataclasses.replace(upd, iterations=found.linearisations, inflations=found.inflations,
                                  message=f"{head} in {found.updates} rounds, {found.registrations} registrations",
                                  seconds=time.perf_counter() - started)
    to_target = deviation_map(pts, target, design.approx.faces, max_distance=MAX_DISTANCE, seed=seed)
    corr = correct_lengths(seen, upd, check=scanned, keep_tolerance=keep_tolerance, verify=verify, params=params)
    if seen is not design:
        corr = dataclasses.replace(corr, design=dataclasses.replace(corr.design, approx=design.approx))
    calibration = None
    try:
        from airmat.asbuilt.updated_calibration import updated_calibration

        calibration = updated_calibration(upd, design, base=base_calibration, scans=(name,))
    except InputError as err:
        notes.append(f"no updated calibration: {err.message}")
    return AsBuilt(design=design, scan=name, surface=surface, reference_xyz=xyz, reference_faces=triangles,
                   registration=reg, points=pts, to_target=to_target, to_prediction=to_pred, update=upd,
                   correction=corr, calibration=calibration, notes=tuple(notes),
                   seconds=time.perf_counter() - started)
