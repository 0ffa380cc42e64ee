"""The alternation of ``airmat correct``: update from a pose, register the scan again onto the updated prediction, repeat.

The first registration fits the scan onto the design's prediction, which the built mattress can miss by
centimetres; ICP then lets the shape's difference pull the pose. So registration and update
(:func:`airmat.asbuilt.update.update`) alternate: each round updates from the pose it has (carried on
from the last round's update), registers the scan again onto the updated prediction from that pose, and
the rounds stop when the pose holds (:data:`POSE_TOL`, at most :data:`REREGISTRATIONS`). Where the first
registration found other poses nearly as good, each gets one round and the one whose scan then lies
nearest its updated prediction goes on (:func:`choose_pose`). A round works on a seeded subset of a large
scan (:func:`round_subset`). SI units (m).
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from airmat.errors import InputError

__all__ = ["MAX_DISTANCE", "REGISTRATION", "REREGISTRATIONS", "POSE_TOL", "ROUND_POINTS", "FIRST_RELINEARISATIONS",
           "Round", "Alternation", "scanned_face", "on_face", "round_subset", "one_round", "units_of", "reregister",
           "alternate", "choose_pose"]

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


def on_face(posed, xyz, triangles, seed) -> tuple:
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


class Round(NamedTuple):
    """One update from a pose: the update, the indices into the scan of the round's points on the predicted face
    (:func:`round_subset`), and the scan registered again onto the updated prediction (None until made)."""

    update: object
    on: np.ndarray
    again: object = None


@dataclass(frozen=True)
class Alternation:
    """Where registration and update ended together, and what it took."""

    registration: object
    last: Round
    linearisations: int
    inflations: int
    registrations: int
    updates: int


def one_round(reg, start, settled, *, design, raw, subset, xyz, triangles, check, resolution, params,
              cut_tolerance, seed, relin, **_) -> Round:
    """One update from the pose ``reg`` carried on from ``start``; the whole budget ``relin`` once ``settled``, else
    :data:`FIRST_RELINEARISATIONS`."""
    from airmat.asbuilt.update import update

    pts, _, on = on_face(reg.apply(raw[subset]), xyz, triangles, seed)
    upd = update(design, pts, check=check, resolution=resolution, params=params, cut_tolerance=cut_tolerance,
                 seed=seed, max_relinearisations=relin if settled else min(relin, FIRST_RELINEARISATIONS), start=start)
    return Round(upd, subset[on])


def units_of(reg) -> str:
    """``register``'s ``units`` that keeps the unit factor ``reg`` found."""
    return "same" if reg.scale == 1.0 else "m-as-mm"


def reregister(reg, upd, raw, name, seed, clouds=None):
    """The scan registered again onto ``upd``'s prediction, from the pose ``reg``, on ``reg``'s voxels (the scan's
    reduction kept in ``clouds``, :func:`~airmat.asbuilt.registration.register`)."""
    from airmat.asbuilt.registration import register

    learned, _, learned_faces = scanned_face(upd.prediction)
    return register(raw, learned, learned_faces, seed=seed, name=name, init=(reg.rotation, reg.translation),
                    local=True, units=units_of(reg), voxel=reg.voxel, clouds=clouds, **REGISTRATION)


def alternate(reg, *, first=None, **kw) -> Alternation:
    """Update from the pose ``reg``, register the scan again onto the updated prediction, and repeat until the pose
    holds (:data:`POSE_TOL`, at most :data:`REREGISTRATIONS` more), each round's update carried on from the last
    (:data:`FIRST_RELINEARISATIONS` a round); then the update with its whole budget ``kw["relin"]``.

    ``kw``: ``design`` and ``check`` of the scanned face; ``xyz``, ``triangles`` the design's prediction
    (:func:`scanned_face`), onto which the points are reduced; the scan ``raw`` and its ``name``, and the update's
    settings (:func:`one_round`). ``first``: the first round at ``reg`` (with its ``again``), when made already.
    """
    raw = kw["raw"]
    upd, linearisations, inflations, registrations, updates = None, 0, 0, 1, 0
    settled = kw["relin"] == 0         # the pose holds: the update alone, with its whole budget
    while True:
        done = first if first is not None else one_round(reg, upd, settled, **kw)
        upd, on = done.update, done.on
        linearisations, inflations, updates = linearisations + upd.iterations, inflations + upd.inflations, updates + 1
        if settled:
            break
        if registrations > REREGISTRATIONS:
            moved = np.inf
        else:
            again = done.again if done.again is not None else reregister(reg, upd, raw, kw["name"], kw["seed"],
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
    return Alternation(registration=reg, last=done, linearisations=linearisations, inflations=inflations,
                       registrations=registrations, updates=updates)


def choose_pose(reg, reference, **kw) -> tuple:
    """Of ``reg``'s pose and its alternatives (:attr:`~airmat.asbuilt.registration.Registration.alternatives`),
    registered onto ``reference`` (vertices, triangles), the one whose scan lies nearest its updated prediction
    after one round of the update: (Registration, its :class:`Round` with ``again``, a note or "").

    A near-symmetric shape built off its prediction can fit a turned pose about as well as the true one; the two
    part once the prediction moves towards the built shape. ``kw`` as :func:`alternate`'s.
    """
    from airmat.asbuilt.registration import register

    raw, name, seed = kw["raw"], kw["name"], kw["seed"]
    poses = [reg]
    for rot, trans in reg.alternatives:
        try:
            poses.append(register(raw, *reference, seed=seed, name=name, init=(rot, trans), units=units_of(reg),
                                  voxel=reg.voxel, clouds=kw["clouds"], **REGISTRATION))
        except InputError:
            continue
    rounds = []
    for p in poses:
        r = one_round(p, None, False, **kw)
        rounds.append(r._replace(again=reregister(p, r.update, raw, name, seed, kw["clouds"])))
    misfit = [r.again.rms for r in rounds]
    best = int(np.argmin(misfit))
    log.info("as-built: %d poses of the scan, registered again after one round of the update: %s mm RMS from "
             "its prediction", len(poses), ", ".join(f"{1e3 * m:.2f}" for m in misfit))
    note = "" if best == 0 else (
        f"{len(poses)} poses of the scan fit the design's prediction about as well; after one round of the update "
        f"the scan lies {1e3 * misfit[best]:.2f} mm RMS from the updated prediction in the registration's "
        f"alternative {best} against {1e3 * misfit[0]:.2f} mm in its first pose: the alternative is kept")
    return poses[best], rounds[best], note
