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
   from where it stopped, until the pose holds (:data:`REREGISTRATIONS`, :data:`POSE_TOL`);
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
from typing import NamedTuple

import numpy as np

from airmat.constants import CUT_TOLERANCE
from airmat.errors import InputError
from airmat.inflation.model import Parameters
from airmat.summary import Summarized, mm

__all__ = ["AsBuilt", "correct", "scanned_face", "scanned_target", "MAX_DISTANCE", "REGISTRATION", "REREGISTRATIONS", "POSE_TOL",
           "FIRST_RELINEARISATIONS", "ROUND_POINTS", "round_subset"]

log = logging.getLogger(__name__)

#: a registered scan point farther than this from the predicted face is not the mattress (m): the
#: floor, clutter, a hand; a built mattress lands up to a few centimetres from its prediction
MAX_DISTANCE = 0.06

#: the registration's thresholds for a built mattress, which lands centimetres from its prediction
#: (a world outside the calibration's 95 % and ±3 mm ties): inliers within 30 mm, refused when they
#: scatter more than 10 mm RMS or cover less than half the face. Measured on vault1 built in such a
#: world (7.4 mm RMS, 72 % covered: kept) and on a scan of the saddle preset against vault1's
#: prediction (12.0 mm, 38 %: refused).
REGISTRATION = {"inlier_distance": 0.03, "max_rms": 0.010, "min_coverage": 0.5}

#: registration and update alternate up to this many more times. The scan is registered first onto the
#: design's prediction, which the built mattress can miss by centimetres, and ICP then lets the shape's
#: difference pull the pose: on vault1 at 40 mm built beyond its calibration (85 % of the face scanned) the
#: points sit 16.9 mm RMS from their true place, slid along the vault, and the update fits (Δ, d) to the
#: slide (17.8 / 89.3 mm against the world's 20.6 / 76.3, not converged). Registered again onto the
#: updated prediction, from the pose it has, and updated again from where it stopped
#: (:func:`airmat.asbuilt.update.update`'s ``start``), the pair converges to the true pose and world
REREGISTRATIONS = 4

#: the alternation stops when registering again moves the points on the face by less than this (m RMS)
POSE_TOL = 0.5e-3

#: scan points a round of the alternation reduces to the predicted face (:func:`round_subset`): twice the update's
#: own subset (:data:`airmat.asbuilt.scan_data.MAX_POINTS`), so that it still gets that many where half the scan is
#: floor and clutter; every point goes into the deviation maps written at the end
ROUND_POINTS = 400_000

#: relinearisations of the first update, before the first registration again: on vault1 two take the
#: scan's misfit from 22 to 0.4 mm, near enough for the updated prediction to carry the pose
FIRST_RELINEARISATIONS = 2


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


def scanned_face(run) -> tuple:
    """A prediction's mattress in Ŝ's frame and the face a scanner above it sees.

    Parameters
    ----------
    run : airmat.check.inflation_check.CheckRun or airmat.asbuilt.update.Prediction
        Anything with an ``inflation`` and its ``deviation`` (the alignment to Ŝ).

    Returns
    -------
    xyz : ndarray of shape (n, 3)
        The mattress's vertices (m).
    surface : str
        ``"top"`` or ``"bottom"`` (:func:`airmat.asbuilt.true_world.upper_face`).
    triangles : ndarray of shape (t, 3)
        That face's triangles.
    """
    from airmat.asbuilt.true_world import upper_face

    xyz = run.deviation.apply(run.inflation.xyz)
    surface, triangles = upper_face(run.inflation.mesh, xyz)
    return xyz, surface, triangles


def _on_face(posed, xyz, triangles, seed) -> tuple:
    """The registered points (M, 3) that lie on the predicted face (within :data:`MAX_DISTANCE`, inside
    its outline), their deviation map against it and the mask (M0,) of ``posed`` they are."""
    from airmat.asbuilt.deviation_map import deviation_map

    to_pred = deviation_map(posed, xyz, triangles, max_distance=MAX_DISTANCE, seed=seed)
    on = np.isfinite(to_pred.per_point)          # the map's vertex means use only these
    return posed[on], dataclasses.replace(to_pred, per_point=to_pred.per_point[on]), on


def round_subset(n: int, seed) -> np.ndarray:
    """Indices (sorted) of the scan points a round of the alternation works on: all of them up to
    :data:`ROUND_POINTS`, else a seeded random subset of that many."""
    if n <= ROUND_POINTS:
        return np.arange(n)
    return np.sort(np.random.default_rng([seed, 3]).choice(n, size=ROUND_POINTS, replace=False))


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


class _Round(NamedTuple):
    """One update from a pose: the update, the indices into the scan of the round's points on the predicted face
    (:func:`round_subset`), and the scan registered again onto the updated prediction (None until made)."""

    update: object
    on: np.ndarray
    again: object = None


@dataclass(frozen=True)
class _Alternation:
    """Where registration and update ended together, and what it took."""

    registration: object
    last: _Round
    linearisations: int
    inflations: int
    registrations: int
    updates: int


def _round(reg, start, settled, *, design, raw, subset, xyz, triangles, check, resolution, params, cut_tolerance,
           seed, relin, **_) -> _Round:
    """One update from the pose ``reg`` carried on from ``start``; the whole budget ``relin`` once ``settled``, else
    :data:`FIRST_RELINEARISATIONS`."""
    from airmat.asbuilt.update import update

    pts, _, on = _on_face(reg.apply(raw[subset]), xyz, triangles, seed)
    upd = update(design, pts, check=check, resolution=resolution, params=params, cut_tolerance=cut_tolerance,
                 seed=seed, max_relinearisations=relin if settled else min(relin, FIRST_RELINEARISATIONS), start=start)
    return _Round(upd, subset[on])


def _units(reg) -> str:
    """``register``'s ``units`` that keeps the unit factor ``reg`` found."""
    return "same" if reg.scale == 1.0 else "m-as-mm"


def _reregister(reg, upd, raw, name, seed, clouds=None):
    """The scan registered again onto ``upd``'s prediction, from the pose ``reg``, on ``reg``'s voxels (the scan's
    reduction kept in ``clouds``, :func:`~airmat.asbuilt.registration.register`)."""
    from airmat.asbuilt.registration import register

    learned, _, learned_faces = scanned_face(upd.prediction)
    return register(raw, learned, learned_faces, seed=seed, name=name, init=(reg.rotation, reg.translation),
                    local=True, units=_units(reg), voxel=reg.voxel, clouds=clouds, **REGISTRATION)


def _alternate(reg, *, first=None, **kw) -> _Alternation:
    """Update from the pose ``reg``, register the scan again onto the updated prediction, and repeat until the pose
    holds (:data:`POSE_TOL`, at most :data:`REREGISTRATIONS` more), each round's update carried on from the last
    (:data:`FIRST_RELINEARISATIONS` a round); then the update with its whole budget ``kw["relin"]``.

    ``kw``: ``design`` and ``check`` of the scanned face; ``xyz``, ``triangles`` the design's prediction
    (:func:`scanned_face`), onto which the points are reduced; the scan ``raw`` and its ``name``, and the update's
    settings (:func:`_round`). ``first``: the first round at ``reg`` (with its ``again``), when made already.
    """
    raw = kw["raw"]
    upd, linearisations, inflations, registrations, updates = None, 0, 0, 1, 0
    settled = kw["relin"] == 0         # the pose holds: the update alone, with its whole budget
    while True:
        done = first if first is not None else _round(reg, upd, settled, **kw)
        upd, on = done.update, done.on
        linearisations, inflations, updates = linearisations + upd.iterations, inflations + upd.inflations, updates + 1
        if settled:
            break
        if registrations > REREGISTRATIONS:
            moved = np.inf
        else:
            again = done.again if done.again is not None else _reregister(reg, upd, raw, kw["name"], kw["seed"],
                                                                          kw["clouds"])
            registrations += 1
            moved = float(np.sqrt(np.mean(np.sum((again.apply(raw[on]) - reg.apply(raw[on])) ** 2, axis=1))))
            log.info("as-built: registered again onto the updated prediction, the points moved %.2f mm RMS and lie "
                     "%.2f mm RMS from it", 1e3 * moved, 1e3 * again.rms)
        first = None
        if moved >= POSE_TOL and registrations <= REREGISTRATIONS:
            reg = again
            continue
        settled = True
        if upd.converged:
            break
    return _Alternation(registration=reg, last=done, linearisations=linearisations, inflations=inflations, registrations=registrations,
                        updates=updates)


def _choose_pose(reg, reference, **kw) -> tuple:
    """Of ``reg``'s pose and its alternatives (:attr:`~airmat.asbuilt.registration.Registration.alternatives`),
    registered onto ``reference`` (vertices, triangles), the one whose scan lies nearest its updated prediction
    after one round of the update: (Registration, its :class:`_Round` with ``again``, a note or "").

    A near-symmetric shape built off its prediction can fit a turned pose about as well as the true one; the two
    part once the prediction moves towards the built shape. ``kw`` as :func:`_alternate`'s.
    """
    from airmat.asbuilt.registration import register

    raw, name, seed = kw["raw"], kw["name"], kw["seed"]
    poses = [reg]
    for rot, trans in reg.alternatives:
        try:
            poses.append(register(raw, *reference, seed=seed, name=name, init=(rot, trans), units=_units(reg),
                                  voxel=reg.voxel, clouds=kw["clouds"], **REGISTRATION))
        except InputError:
            continue
    rounds = []
    for p in poses:
        r = _round(p, None, False, **kw)
        rounds.append(r._replace(again=_reregister(p, r.update, raw, name, seed, kw["clouds"])))
    misfit = [r.again.rms for r in rounds]
    best = int(np.argmin(misfit))
    log.info("as-built: %d poses of the scan, registered again after one round of the update: %s mm RMS from "
             "its prediction", len(poses), ", ".join(f"{1e3 * m:.2f}" for m in misfit))
    note = "" if best == 0 else (
        f"{len(poses)} poses of the scan fit the design's prediction about as well; after one round of the update "
        f"the scan lies {1e3 * misfit[best]:.2f} mm RMS from the updated prediction in the registration's "
        f"alternative {best} against {1e3 * misfit[0]:.2f} mm in its first pose: the alternative is kept")
    return poses[best], rounds[best], note


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
        reg, first, note = _choose_pose(reg, reference, **kw)
        if note:
            notes.append(note)
    found = _alternate(reg, first=first, **kw)
    upd, reg = found.last.update, found.registration
    pts, to_pred, _ = _on_face(reg.apply(raw), xyz, triangles, seed)     # every scan point, for the maps
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
