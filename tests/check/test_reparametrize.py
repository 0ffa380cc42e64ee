"""Ŝ re-parametrized in a realized metric: the same surface, its points where the face puts them."""

import numpy as np
import pytest

from airmat.check.reparametrize import realized_ratio, reparametrize
from airmat.design.mattress import Mattress, triangulate_mattress

R = 0.3          # cylinder radius (m)


def _cylinder(uv, scale=1.0, shift=0.0):
    """The cylinder of radius R about the y axis, arc length ``scale * u + shift`` along it."""
    s = scale * uv[:, 0] + shift
    return np.column_stack([R * np.sin(s / R), uv[:, 1], R * (1.0 - np.cos(s / R))])


@pytest.fixture(scope="module")
def omega():
    return triangulate_mattress(Mattress(0.4, 0.3), spacing=0.02)


def _face_deviation(face, approx_xyz, uv):
    # the deviation of a face known at Ω's vertices from Ŝ, as the check computes it (Kabsch, point to point)
    from scipy.spatial.transform import Rotation

    tc, fc = approx_xyz.mean(axis=0), face.mean(axis=0)
    rot, _ = Rotation.align_vectors(approx_xyz - tc, face - fc)
    return np.sqrt(np.mean(np.sum(((face - fc) @ rot.as_matrix().T + tc - approx_xyz) ** 2, axis=1)))


def test_a_face_shortened_along_the_bend_is_found_on_the_same_cylinder(omega):
    # exact ground truth: the face is the same cylinder with its arc length along u shortened by 3 %
    # (a metric the cylinder carries exactly), so Ŝ's points can slide onto the face's, up to a rigid motion
    uv, faces = omega
    approx = _cylinder(uv)
    face = _cylinder(uv, scale=0.97) + [0.1, 0.2, -0.3]           # in any rigid position
    before = _face_deviation(face, approx, uv)
    rep = reparametrize(approx, uv, faces, face)
    assert rep.converged
    after = _face_deviation(face, rep.xyz, uv)
    assert before > 2e-3 and after < 0.05 * before                # measured: 3.4 mm -> 0.05 mm
    # the edges took the face's lengths ...
    target, got = realized_ratio(face, uv, faces), realized_ratio(rep.xyz, uv, faces)
    assert np.max(np.abs(got - target)) < 2e-3 < np.max(np.abs(realized_ratio(approx, uv, faces) - target))
    # ... and the points stayed on the cylinder: moved along it, not off it
    radius = np.hypot(rep.xyz[:, 0], rep.xyz[:, 2] - R)
    assert np.max(np.abs(radius - R)) < 2e-4 and rep.off_max < 2e-4
    assert rep.moved_max > 4e-3 and rep.moved_rms > 2e-3


def test_a_face_in_the_same_metric_moves_nothing(omega):
    uv, faces = omega
    approx = _cylinder(uv)
    rep = reparametrize(approx, uv, faces, _cylinder(uv, shift=0.05))      # slid along: the same metric
    assert rep.moved_max < 2e-4 and rep.off_max < 2e-4
