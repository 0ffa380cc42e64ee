"""Closest points on a target and their continuation across its rim (airmat.design.closest_point)."""

import numpy as np
import pytest

from airmat.synthetic.targets import cylinder
from airmat.design.closest_point import MeshProjector
from airmat.design.mattress import Mattress, triangulate_mattress


@pytest.fixture(scope="module")
def square():
    """The unit square in z = 0 as a 10 × 10 grid (normals +z)."""
    uv, faces = triangulate_mattress(Mattress(1.0, 1.0), spacing=0.1)
    return MeshProjector(np.column_stack([uv, np.zeros(len(uv))]), faces)


def test_inside_the_rim_both_are_the_foot_on_the_surface(square):
    rng = np.random.default_rng(0)
    p = np.column_stack([rng.uniform(0.05, 0.95, (200, 2)), rng.uniform(-0.3, 0.3, 200)])
    near, ext = square.closest(p), square.closest_extended(p)
    assert not near.on_rim.any()
    # open3d picks the triangle in float32: a foot near an edge may land on it (1e-4 m aside),
    # at a distance that differs from the true one only in float32 rounding
    assert np.abs(near.points[:, :2] - p[:, :2]).max() < 1e-4 and np.abs(near.points[:, 2]).max() == 0
    assert np.allclose(near.distance, np.abs(p[:, 2]), rtol=0, atol=1e-8)
    assert np.array_equal(ext.points, near.points)


def test_beyond_the_rim_only_the_normal_component_is_removed(square):
    rng = np.random.default_rng(1)
    # points beyond each of the four sides and the corners
    xy = rng.uniform(-0.5, 1.5, (400, 2))
    xy = xy[((xy < 0) | (xy > 1)).any(axis=1)]
    p = np.column_stack([xy, rng.uniform(-0.3, 0.3, len(xy))])
    near, ext = square.closest(p), square.closest_extended(p)
    assert near.on_rim.all()
    assert np.allclose(near.points[:, :2], np.clip(xy, 0, 1), atol=1e-12)   # S ends at its rim
    assert np.allclose(ext.points, np.column_stack([xy, np.zeros(len(xy))]), atol=1e-12)
    assert np.allclose(ext.distance, np.abs(p[:, 2]), atol=1e-12)


def test_a_point_on_the_rim_edge_is_flagged_and_continuous(square):
    # level with the rim edge x = 1: the foot is on the rim and both projections agree
    p = np.array([[1.0, 0.43, 0.2], [1.0 - 1e-9, 0.43, 0.2], [1.0 + 1e-9, 0.43, 0.2]])
    near, ext = square.closest(p), square.closest_extended(p)
    assert near.on_rim.all()
    assert np.abs(ext.points - [[1.0, 0.43, 0.0]]).max() < 2e-9


def test_interior_edges_and_vertices_are_not_rim(square):
    # feet on interior grid lines and grid vertices
    p = np.array([[0.5, 0.5, 0.1], [0.3, 0.55, -0.2], [0.55, 0.3, 0.05]])
    assert not square.closest(p).on_rim.any()


def test_cylinder_continued_along_its_axis_and_by_its_tangent_plane():
    r = 0.3
    surf = cylinder(r, length=0.6, arc=0.6, spacing=0.01)
    proj = MeshProjector(surf.vertices, surf.faces)
    theta = np.linspace(-0.9, 0.9, 7)
    # beyond an end of the axis, on the cylinder's continuation: A2 leaves them (nearly) in place
    p = np.column_stack([np.full(7, 0.4), r * np.sin(theta), r * np.cos(theta) - r])
    ext = proj.closest_extended(p)
    assert proj.closest(p).on_rim.all() and proj.closest(p).distance.min() > 0.099
    sagitta = r * (1 - np.cos(0.5 * 0.01 / r))    # of one facet of the 10 mm mesh
    assert ext.distance.max() < 1.01 * sagitta
    # beyond the straight rim (arc 0.3 m each side of the crown): pulled onto the plane of the
    # last facet (its normal at the middle of its 10 mm of arc), along that normal only
    phi = 0.3 / r
    psi = phi - 0.5 * 0.01 / r
    normal = np.array([0.0, np.sin(psi), np.cos(psi)])
    rim = np.array([0.1, r * np.sin(phi), r * np.cos(phi) - r])
    q = rim + 0.1 * np.array([0.0, np.cos(phi), -np.sin(phi)]) + np.array([0.0, 0.0, 0.05])
    got = proj.closest_extended(q[None]).points[0]
    assert abs((got - rim) @ normal) < 1e-9                           # on that plane
    assert np.linalg.norm(np.cross(q - got, normal)) < 1e-9           # moved along its normal
    near = proj.closest(q[None])
    assert near.on_rim[0] and np.allclose(near.points[0], rim, atol=1e-6)   # plain: back onto the rim
    assert np.linalg.norm(q - got) < 0.5 * near.distance[0]


def test_the_rim_test_of_the_faces_touching_the_rim_is_the_test_of_every_point(square, monkeypatch):
    # _on_rim tests only the points whose face has a rim edge or corner; with every face counted as
    # touching the rim (the test it replaced, of every point) each point gets the same answer
    rng = np.random.default_rng(3)
    p = np.column_stack([rng.uniform(-0.2, 1.2, (3000, 2)), rng.uniform(-0.3, 0.3, 3000)])
    p[:50, :2] = np.round(p[:50, :2], 1)                  # on grid lines and corners, inside and on the rim
    near = square.closest(p)
    tri = square._vertices[square._faces[near.face]]
    assert (~square._rim_face[near.face]).sum() > len(p) // 4     # the restriction skips many of them
    monkeypatch.setattr(square, "_rim_face", np.ones_like(square._rim_face))
    every = square._on_rim(tri, near.face, near.points)
    assert 0 < every.sum() < len(p) and np.array_equal(near.on_rim, every)


def test_the_answers_do_not_depend_on_the_threads():
    """The default takes the idle cores; one thread or two give the same bits."""
    t = cylinder(0.3, length=0.6, arc=0.6, spacing=0.005)
    rng = np.random.default_rng(3)
    p = t.vertices[rng.integers(0, len(t.vertices), 3000)] + rng.normal(0, 0.02, (3000, 3))
    one, two = (MeshProjector(t.vertices, t.faces, threads=k).closest_extended(p) for k in (1, 2))
    for name in ("points", "face", "normal", "distance", "on_rim"):
        assert np.array_equal(getattr(one, name), getattr(two, name)), name
    assert MeshProjector(t.vertices, t.faces)._threads >= 1


def test_a_projector_that_chose_its_threads_looks_again_while_it_is_used(monkeypatch):
    import airmat.cores
    import airmat.design.closest_point as cp

    clock, busy = [100.0], [0]
    monkeypatch.setattr(cp.time, "monotonic", lambda: clock[0])
    monkeypatch.setattr(airmat.cores, "usable_cores", lambda: 2)
    monkeypatch.setattr(airmat.cores, "busy_elsewhere", lambda samples=5: busy[0])
    t = cylinder(0.3, length=0.3, arc=0.3, spacing=0.02)
    auto, fixed = MeshProjector(t.vertices, t.faces), MeshProjector(t.vertices, t.faces, threads=2)
    assert auto.threads == 2 and fixed.threads == 2
    busy[0] = 1                                             # another process starts
    clock[0] += 0.5 * cp.RECHECK_SECONDS
    assert auto.threads == 2                                # not looked at yet
    clock[0] += cp.RECHECK_SECONDS
    assert auto.threads == 1 and fixed.threads == 2         # the given number stays
    p = t.vertices[:50] + 0.01
    assert np.array_equal(auto.closest(p).points, fixed.closest(p).points)
    busy[0] = 0
    clock[0] += cp.RECHECK_SECONDS
    assert auto.threads == 2
    busy[0] = None                                          # the system does not say
    clock[0] += cp.RECHECK_SECONDS
    assert auto.threads == 1
