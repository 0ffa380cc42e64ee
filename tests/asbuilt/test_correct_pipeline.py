"""airmat.asbuilt.pipeline: the registration and the update alternate until the pose holds.

The truth: a synthetic scan (:func:`airmat.synthetic.built_scan.scan_surface`) of vault1 built in a world
2 mm beyond its calibration's 95 % intervals, 85 % of its face seen, a floor and clutter around it, in a
random frame in metres; its pose and the world are known.
"""

from dataclasses import replace

import numpy as np
import pytest

import airmat.asbuilt.alternation as alternation
from airmat.asbuilt.alternation import REGISTRATION, round_subset, scanned_face
from airmat.asbuilt.pipeline import correct
from airmat.errors import InputError
from airmat.asbuilt.registration import register
from airmat.asbuilt.true_world import built_world, median_world
from airmat.check.inflation_check import check
from airmat.design.calibration_source import CalibrationSource
from airmat.design.pipeline import DesignParams, design
from airmat.design.presets import preset
from airmat.synthetic.built_scan import SURFACE, scan_surface

RESOLUTION = 0.04


def vault1_with_posterior():
    """vault1 (open loop) designed with a narrow test posterior of (Δ, d); (design, that posterior)."""
    target, mattress = preset("vault1")
    d = design(target, mattress, params=DesignParams(), progress=False)
    rng = np.random.default_rng(3)
    cal = CalibrationSource(L=d.calibration.L, delta=rng.normal(0.0179, 0.0004, 2000),
                            d=rng.normal(0.0689, 0.0025, 2000), source="test", uncalibrated=False,
                            label="test posterior", sigma=None)
    return replace(d, calibration=cal), cal


def built_and_scanned(d, cal):
    """``d``'s check at :data:`RESOLUTION`, the world 2 mm beyond ``cal``'s 95 % intervals (ties ±3 mm), and a
    50 000-point scan of it (85 % of the face, floor, clutter, a random frame in metres)."""
    chk = check(d, resolution=RESOLUTION, envelope=False)
    world = replace(median_world(d, cut_tolerance=0.003), delta=float(np.percentile(cal.delta, 97.5)) + 0.002,
                    d=float(np.percentile(cal.d, 97.5)) + 0.002)
    built = built_world(d, world, resolution=RESOLUTION, seed=0)
    scan = scan_surface(built.xyz, built.upper_triangles, n_points=50_000, noise=0.0005, coverage=0.85,
                        units="m", seed=[0, 1], floor_z=float(built.xyz[:, 2].min()))
    return chk, world, scan


def register_on_median(scan, chk):
    """The scan registered onto the check's median prediction alone."""
    xyz, _, faces = scanned_face(chk.runs["median"])
    return register(scan.points, xyz, faces, seed=0, **REGISTRATION)


def pose_error(reg, scan) -> float:
    """RMS distance (m) of the scan's face points, registered, from their true places."""
    on = scan.labels == SURFACE
    truth = (scan.points[on] - scan.translation) @ scan.rotation
    return float(np.sqrt(np.mean(np.sum((reg.apply(scan.points[on]) - truth) ** 2, axis=1))))


@pytest.mark.slow
def test_registering_again_onto_the_updated_prediction_finds_the_pose_the_first_registration_missed():
    d, cal = vault1_with_posterior()
    chk, world, scan = built_and_scanned(d, cal)
    first = register_on_median(scan, chk)
    res = correct(d, scan.points, check=chk, resolution=RESOLUTION, seed=0)
    # onto the design's prediction, the built shape's difference slides the scan along the vault (measured
    # 15.7 mm); onto the updated prediction, the pose is found to the scan's noise (0.52 mm)
    assert pose_error(first, scan) > 0.005
    assert pose_error(res.registration, scan) < 0.001
    lo, hi = res.update.interval95
    truth = np.array([world.delta, world.d])
    assert res.update.converged and np.all((lo <= truth) & (truth <= hi)), (lo, hi, truth)
    assert "registrations" in res.update.message


def test_a_round_works_on_a_seeded_subset_of_a_large_scan():
    small = round_subset(1000, seed=0)
    np.testing.assert_array_equal(small, np.arange(1000))
    n = alternation.ROUND_POINTS + 12_345
    a, b = round_subset(n, seed=0), round_subset(n, seed=0)
    np.testing.assert_array_equal(a, b)
    assert len(a) == alternation.ROUND_POINTS and len(np.unique(a)) == len(a) and np.all(np.diff(a) > 0)
    assert a[-1] < n and not np.array_equal(a, round_subset(n, seed=1))


@pytest.mark.slow
def test_rounds_on_a_subset_of_the_scan_find_the_pose_and_the_world_and_the_maps_keep_every_point(monkeypatch):
    """The vault1 world of the first test with the rounds on 20 000 of the scan's points (the update's own subset
    and the registrations' voxels unchanged): the pose and the world are found as with every point, and the
    deviation maps written at the end hold every scan point on the face."""
    monkeypatch.setattr(alternation, "ROUND_POINTS", 20_000)
    d, cal = vault1_with_posterior()
    chk, world, scan = built_and_scanned(d, cal)
    res = correct(d, scan.points, check=chk, resolution=RESOLUTION, seed=0)
    assert pose_error(res.registration, scan) < 0.001
    lo, hi = res.update.interval95
    truth = np.array([world.delta, world.d])
    assert res.update.converged and np.all((lo <= truth) & (truth <= hi)), (lo, hi, truth)
    on_face = np.count_nonzero(scan.labels == SURFACE)
    assert len(res.points) > 20_000 and len(res.points) > 0.9 * on_face
    assert len(res.to_prediction.per_point) == len(res.points)


@pytest.mark.slow
def test_a_scan_the_median_prediction_refuses_is_registered_onto_the_envelope_and_its_pose_found():
    """vault1 with the paper's stated uncertainty (Δ ± 3 mm, d ± 5 mm), built 2 mm beyond its 95 % intervals:
    onto the median prediction the scan's points scatter 11 mm RMS and are refused; the hi95 prediction takes
    them, and the alternation finds the pose."""
    target, mattress = preset("vault1")
    d = design(target, mattress, params=DesignParams(), progress=False)
    chk, _, scan = built_and_scanned(d, d.calibration)
    with pytest.raises(InputError, match="this design"):
        register_on_median(scan, chk)
    res = correct(d, scan.points, check=chk, resolution=RESOLUTION, seed=0)
    assert any("registered first onto its hi95 prediction" in n for n in res.notes), res.notes
    assert pose_error(res.registration, scan) < 0.001          # measured 0.84 mm
    assert res.update.converged


@pytest.mark.slow
def test_of_two_poses_that_fit_the_prediction_about_as_well_the_one_the_update_can_follow_is_kept():
    """vault1 (open loop, the paper's values) built at Δ = 22, d = 75 mm with ±3 mm ties (the guide's example world,
    at 40 mm): onto the median prediction, the half-turned pose of this scan holds slightly more inliers than the
    true one (measured 14 637 against 14 488 at 20 mm); after one round of the update the true pose's scan lies
    0.77 mm RMS from the updated prediction, the half-turned one's 2.41 mm."""
    target, mattress = preset("vault1")
    d = design(target, mattress, params=DesignParams(), progress=False)
    chk = check(d, resolution=RESOLUTION, envelope=False)
    world = replace(median_world(d, cut_tolerance=0.003), delta=0.022, d=0.075)
    built = built_world(d, world, resolution=RESOLUTION, seed=7)
    scan = scan_surface(built.xyz, built.upper_triangles, n_points=50_000, noise=0.0005, coverage=0.85, units="m",
                        seed=[0, 1], floor_z=float(built.xyz[:, 2].min()))
    first = register_on_median(scan, chk)
    assert pose_error(first, scan) > 0.1                      # half-turned: measured 560 mm
    assert len(first.alternatives) >= 1
    near = [pose_error(replace(first, rotation=r, translation=t), scan) for r, t in first.alternatives]
    assert min(near) < 0.05                                   # the true pose's start: measured 24 mm
    res = correct(d, scan.points, check=chk, resolution=RESOLUTION, seed=0)
    assert pose_error(res.registration, scan) < 0.001         # measured 0.27 mm
    assert any("alternative 1" in n for n in res.notes), res.notes
    assert res.update.converged
