"""Synthetic specimen scans: seeded, and geometrically what they claim to be."""

import numpy as np
import pytest

from airmat.errors import InputError
from airmat.synthetic.specimen_scan import CLUTTER, FLOOR, SPECIMEN, specimen_scan


def _radial(scan, pts):
    """Distance of points to the true axis (m)."""
    w = pts - scan.center
    return np.linalg.norm(w - np.outer(w @ scan.axis, scan.axis), axis=1)


def test_same_seed_same_points_other_seed_other_points():
    a = specimen_scan(4.0, n_points=5000, seed=3)
    b = specimen_scan(4.0, n_points=5000, seed=3)
    c = specimen_scan(4.0, n_points=5000, seed=4)
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.labels, b.labels)
    assert a.points.shape == c.points.shape == (5000, 3)
    assert not np.allclose(a.points, c.points)


def test_point_budget_and_labels():
    s = specimen_scan(2.0, n_points=20_000, outlier_fraction=0.05, seed=1)
    counts = np.bincount(s.labels, minlength=3)
    assert counts.sum() == 20_000
    assert counts[CLUTTER] == 1000
    assert counts[FLOOR] == 6000  # default floor_fraction 0.3
    assert counts[SPECIMEN] == 13_000


@pytest.mark.parametrize("kappa, arc", [(1.0, 40.0), (6.0, 75.0), (15.0, 120.0)])
def test_clean_specimen_lies_on_its_cylinder_over_the_stated_arc(kappa, arc):
    s = specimen_scan(kappa, n_points=20_000, noise=0.0, groove_depth=0.0, holes=False,
                      density_variation=0.0, arc_deg=arc, seed=2)
    spec = s.points[s.labels == SPECIMEN]
    np.testing.assert_allclose(_radial(s, spec), 1.0 / kappa, rtol=1e-12)
    # angular extent about the axis, in the specimen frame (axis = y)
    local = (spec - s.translation) @ s.rotation
    phi = np.degrees(np.arctan2(local[:, 0], local[:, 2]))
    assert np.ptp(phi) == pytest.approx(arc, rel=0.01)
    assert s.arc_deg == pytest.approx(arc)


def test_noise_level_is_the_stated_one():
    s = specimen_scan(3.0, n_points=40_000, noise=0.001, groove_depth=0.0, arc_deg=60, seed=5)
    r = _radial(s, s.points[s.labels == SPECIMEN]) - s.radius
    assert np.std(r) == pytest.approx(0.001, rel=0.05)


def test_grooves_dip_at_the_string_ends():
    s = specimen_scan(2.0, n_points=40_000, noise=0.0, holes=False, groove_depth=0.004,
                      arc_deg=90, seed=7, L=0.3)
    assert len(s.groove_s) >= 1
    assert np.all(np.diff(s.groove_s) == pytest.approx(0.3))
    spec = s.points[s.labels == SPECIMEN]
    dip = s.radius - _radial(s, spec)
    assert dip.max() == pytest.approx(0.004, rel=0.05)  # the deepest point sits on a groove line
    assert np.median(dip) < 1e-4  # most of the face is undisturbed


def test_floor_is_a_plane_below_the_specimen_and_the_pose_is_random():
    s = specimen_scan(3.0, n_points=20_000, noise=0.0, arc_deg=60, seed=11)
    floor = s.points[s.labels == FLOOR]
    h = (floor - s.center) @ s.normal
    assert np.ptp(h) < 1e-9  # flat
    spec_h = (s.points[s.labels == SPECIMEN] - s.center) @ s.normal
    assert h[0] < spec_h.min()  # under the specimen
    assert np.max(np.abs(s.axis)) < 0.999  # not axis-aligned
    np.testing.assert_allclose(s.rotation @ s.rotation.T, np.eye(3), atol=1e-12)


def test_flat_strip_on_a_floor_is_two_parallel_planes_thickness_apart():
    s = specimen_scan(0.0, n_points=20_000, noise=0.0, groove_depth=0.0, thickness=0.07, seed=4)
    assert s.radius == np.inf and s.arc_deg == 0.0
    top = (s.points[s.labels == SPECIMEN] - s.center) @ s.normal
    floor = (s.points[s.labels == FLOOR] - s.center) @ s.normal
    np.testing.assert_allclose(top, 0.0, atol=1e-12)
    np.testing.assert_allclose(floor, -0.07, atol=1e-12)


def test_holes_remove_patches():
    full = specimen_scan(1.0, n_points=30_000, holes=False, density_variation=0.0, noise=0.0,
                         groove_depth=0.0, seed=9, pose=False)
    holed = specimen_scan(1.0, n_points=30_000, holes=True, n_holes=3, hole_radius=0.05,
                          density_variation=0.0, noise=0.0, groove_depth=0.0, seed=9, pose=False)
    # in the specimen frame (axis y) the holed face leaves empty 2 cm cells the full one fills
    def empty_cells(s):
        p = s.points[s.labels == SPECIMEN]
        ij = np.floor(np.column_stack([np.arctan2(p[:, 0], p[:, 2]), p[:, 1]]) / 0.02).astype(int)
        ij -= ij.min(axis=0)
        grid = np.zeros(ij.max(axis=0) + 1, dtype=int)
        np.add.at(grid, tuple(ij.T), 1)
        return np.count_nonzero(grid == 0)
    assert empty_cells(holed) > empty_cells(full) + 5


@pytest.mark.parametrize("bad", [dict(kappa=-1.0), dict(kappa=np.nan), dict(kappa=1.0, n_points=10),
                                 dict(kappa=1.0, outlier_fraction=0.7),
                                 dict(kappa=1.0, arc_deg=270.0)])
def test_bad_parameters_raise_input_error(bad):
    kappa = bad.pop("kappa")
    with pytest.raises(InputError):
        specimen_scan(kappa, **bad)
