"""Scan points in spatial order (airmat.asbuilt.spatial_order): a permutation cell by cell, and the queries that use
it give the answers of the points in any order."""

import numpy as np

from airmat.asbuilt.deviation_map import deviation_map
from airmat.asbuilt.scan_data import scan_data
from airmat.asbuilt.spatial_order import CELLS, inverse, spatial_order
from tests.asbuilt.test_deviation_map import bumped_scan, vault


def test_the_order_is_a_permutation_that_runs_cell_by_cell():
    rng = np.random.default_rng(0)
    p = rng.uniform([0.0, 0.0, 0.0], [0.8, 0.7, 0.1], (20_000, 3))
    order = spatial_order(p)
    assert np.array_equal(np.sort(order), np.arange(len(p)))
    size = np.ptp(p, axis=0).max() / CELLS
    key = np.floor((p[order] - p.min(axis=0)) / size).astype(int)
    # x cells never decrease; within an x cell, y cells never decrease
    assert np.all(np.diff(key[:, 0]) >= 0)
    same_x = np.diff(key[:, 0]) == 0
    assert np.all(np.diff(key[:, 1])[same_x] >= 0)
    assert np.array_equal(p[order][inverse(order)], p)
    # a single point, no points, all points at one place: still permutations
    assert spatial_order(p[:1]).tolist() == [0]
    assert spatial_order(p[:0]).size == 0
    assert np.array_equal(spatial_order(np.zeros((5, 3))), np.arange(5))


def test_the_deviation_map_of_a_shuffled_scan_is_the_same_point_for_point():
    v, f = vault()
    pts, _, _ = bumped_scan(n=30_000)
    shuffle = np.random.default_rng(1).permutation(len(pts))
    a = deviation_map(pts, v, f, seed=0)
    b = deviation_map(pts[shuffle], v, f, seed=0)
    assert np.array_equal(a.per_point[shuffle], b.per_point, equal_nan=True)
    np.testing.assert_allclose(a.per_vertex, b.per_vertex, rtol=0, atol=1e-15)


def test_the_scan_data_of_a_shuffled_scan_is_the_same():
    v, f = vault()
    pts, _, _ = bumped_scan(n=30_000)
    pts = pts[pts[:, 2] < 0.05]                                        # the clutter off
    shuffle = np.random.default_rng(2).permutation(len(pts))
    a, b = scan_data(pts, v, f), scan_data(pts[shuffle], v, f)
    assert a.n_used == b.n_used and np.array_equal(a.covered, b.covered)
    np.testing.assert_allclose(a.observed, b.observed, rtol=0, atol=1e-15)
    assert abs(a.point_sd - b.point_sd) < 1e-15
