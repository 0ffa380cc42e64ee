import numpy as np

from airmat.design.mattress import Mattress, triangulate_mattress
from airmat.report.mesh import MAX_DISPLAY_VERTICES, display_grid


def test_a_large_grid_is_decimated_to_the_budget_keeping_its_corners():
    uv, faces = triangulate_mattress(Mattress(2.6, 1.6), spacing=0.01)  # 261 x 161 grid
    keep, tri = display_grid(uv, faces)
    assert len(keep) <= MAX_DISPLAY_VERTICES < len(uv)
    sub = uv[keep]
    assert np.allclose(sub.min(axis=0), [0, 0]) and np.allclose(sub.max(axis=0), [2.6, 1.6])
    assert tri.min() == 0 and tri.max() == len(keep) - 1
    # the triangles cover Ω once: their areas add up to W * H
    a, b, c = sub[tri[:, 0]], sub[tri[:, 1]], sub[tri[:, 2]]
    area = 0.5 * np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
    assert np.isclose(area.sum(), 2.6 * 1.6)


def test_a_small_or_irregular_mesh_is_kept_as_it_is():
    uv, faces = triangulate_mattress(Mattress(0.83, 0.74), spacing=0.02)
    keep, tri = display_grid(uv, faces)
    assert np.array_equal(keep, np.arange(len(uv))) and np.array_equal(tri, faces)
    rng = np.random.default_rng(0)
    pts = rng.random((20000, 2))
    keep, tri = display_grid(pts, faces)
    assert len(keep) == 20000
