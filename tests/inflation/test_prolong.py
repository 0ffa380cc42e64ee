"""Coarse-to-fine continuation: exact for affine shapes, and it lands on the same equilibrium."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from airmat.inflation.mesh import build_mattress_mesh
from airmat.inflation.prolong import coarse_resolutions, prolong
from airmat.inflation.simulate import inflate
from airmat.inflation.strings import StringSet


def test_prolongation_reproduces_any_affine_map_of_the_faces():
    coarse = build_mattress_mesh(0.6, 0.4, 0.07, resolution=0.1)
    fine = build_mattress_mesh(0.6, 0.4, 0.07, resolution=0.05)
    a = np.array([[0.9, 0.2, -0.1], [0.1, 1.1, 0.3], [0.05, -0.2, 0.8]])
    t = np.array([0.3, -0.2, 1.0])
    got = prolong(coarse, coarse.vertices @ a.T + t, fine)
    np.testing.assert_allclose(got, fine.vertices @ a.T + t, atol=1e-12)


def test_levels_double_up_to_the_coarsest_and_respect_the_strings():
    assert coarse_resolutions(0.02, coarsest=0.08) == [0.02, 0.04, 0.08]
    assert coarse_resolutions(0.02, coarsest=0.08, shortest_span=0.3, per_string=4) == [0.02, 0.04]
    assert coarse_resolutions(0.05, coarsest=0.08) == [0.05]


def test_continuation_and_a_direct_solve_reach_the_same_equilibrium():
    mesh = build_mattress_mesh(0.6, 0.4, 0.07, resolution=0.025)
    s = StringSet(np.array([[0.1, 0.1], [0.1, 0.3]]), np.array([[0.5, 0.1], [0.5, 0.3]]),
                  np.array([False, False]), np.array([0.3, 0.3]))
    multi = inflate(mesh, s)                                  # 25 -> 50 mm continuation
    direct = inflate(mesh, s, coarsest=0.025)                 # no continuation
    assert multi.converged and direct.converged
    assert multi.stages > direct.stages                       # the coarse ramp + the fine level
    assert multi.energy == pytest.approx(direct.energy, rel=1e-9)
    # the same shape up to a rigid motion (the pinned vertices differ between the meshes)
    a, b = multi.mid_surface, direct.mid_surface
    a0, b0 = a - a.mean(axis=0), b - b.mean(axis=0)
    rot, _ = Rotation.align_vectors(b0, a0)
    gap = np.linalg.norm(rot.apply(a0) - b0, axis=1).max()
    assert gap < 1e-4                                         # m
