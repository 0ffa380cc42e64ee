"""The U_A relaxation of Ω onto a target (airmat.design.relax, airmat.design.placement)."""

import logging

import numpy as np
import pytest
from scipy.spatial import cKDTree

from airmat.errors import ConvergenceError, InputError
from airmat.synthetic.targets import cylinder
from airmat.design.closest_point import MeshProjector
from airmat.design.constructibility import edge_sigma
from airmat.design.mattress import Mattress, triangulate_mattress
from airmat.design.placement import auto_placement, candidate_placements, placement_matrix
from airmat.design.relax import relax_to_target, umbrella_operator
from airmat.design.target import Target

R = 0.3
MATTRESS = Mattress(0.5, 0.4)


@pytest.fixture(scope="module")
def cyl():
    """A cylinder of radius 0.3 m along x: developable, so Ŝ can lie on it unstrained."""
    return Target.from_mesh(cylinder(R, length=0.8, arc=0.75, spacing=0.01))


@pytest.fixture(scope="module")
def mesh():
    return triangulate_mattress(MATTRESS, spacing=0.025)


@pytest.fixture(scope="module")
def relaxed(cyl, mesh):
    return relax_to_target(*mesh, cyl, progress=False)


def _radius(xyz):
    """Distance of points to the cylinder's axis (the line y = 0, z = -R)."""
    return np.hypot(xyz[:, 1], xyz[:, 2] + R)


def test_converges_onto_a_developable_target(relaxed, mesh):
    uv, faces = mesh
    assert relaxed.converged and relaxed.residual < 1e-4
    assert "converged" in relaxed.message and relaxed.n_iter < 200
    _, sigma = edge_sigma(relaxed.xyz, uv, faces)
    assert np.abs(sigma - 1).max() < 2e-3            # isometric: edges keep their length
    assert relaxed.distance["max"] < 2e-4            # and it lies on S (0.2 mm)
    assert np.abs(_radius(relaxed.xyz) - R).max() < 2e-4
    assert relaxed.energy["U_A"] == pytest.approx(sum(relaxed.energy[k] for k in ("U_A1", "U_A2", "U_A3")))


def test_auto_placement_centres_the_long_side_on_the_axis(relaxed, cyl):
    mat = relaxed.placement
    assert np.allclose(mat[:3, :3] @ [1, 0, 0], [1, 0, 0], atol=1e-6)   # long side (u) along the axis
    assert np.allclose(mat[:3, :3] @ [0, 0, 1], [0, 0, 1], atol=1e-6)   # top normal: the target's normals
    centre = mat[:3, :3] @ [0.25, 0.2, 0] + mat[:3, 3]
    assert np.allclose(centre, [0, 0, 0], atol=1e-3)                      # on the crown
    # the relaxed sheet stays centred and wraps symmetrically around the crown
    assert np.abs(relaxed.xyz[:, :2].mean(axis=0)).max() < 1e-3


def test_top_normal_follows_target_orientation(cyl):
    flipped = Target(cyl.vertices, cyl.faces[:, ::-1])
    mat = auto_placement(flipped, 0.5, 0.4)
    assert np.allclose(mat[:3, 2], [0, 0, -1], atol=1e-6)


def test_deterministic(cyl, mesh, relaxed):
    again = relax_to_target(*mesh, cyl, progress=False)
    assert np.array_equal(again.xyz, relaxed.xyz)
    assert again.n_iter == relaxed.n_iter


def test_placement_option_moves_the_sheet(cyl, mesh):
    # start 0.1 m further along the axis, rotated 90 degrees: long side across the arc
    rot = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])
    res = relax_to_target(*mesh, cyl, placement=([0.1, 0.0, 0.0], rot), progress=False)
    assert res.converged
    uv, _ = mesh
    assert res.xyz[:, 0].mean() == pytest.approx(0.1, abs=2e-3)
    # the u axis now runs around the cylinder: the rim u = 0 is a generator (a line along x),
    # the rim v = 0 an arc in a plane x = const
    rim_u0, rim_v0 = res.xyz[uv[:, 0] < 1e-9], res.xyz[uv[:, 1] < 1e-9]
    assert np.ptp(rim_u0[:, 1:], axis=0).max() < 2e-3 and np.ptp(rim_u0[:, 0]) > 0.39
    assert np.ptp(rim_v0[:, 0]) < 2e-3 and np.ptp(rim_v0[:, 1]) > 0.4
    assert np.abs(_radius(res.xyz) - R).max() < 3e-4
    as_matrix = placement_matrix(([0.1, 0.0, 0.0], rot), 0.5, 0.4)
    same = relax_to_target(*mesh, cyl, placement=as_matrix, progress=False)
    assert np.array_equal(same.xyz, res.xyz)


@pytest.mark.parametrize("bad", [np.eye(3), np.diag([1.0, 1, -1, 1]), 2 * np.eye(4),
                                 ([0, 0, 0], np.diag([1.0, 1, -1]))])
def test_placement_must_be_rigid(bad):
    with pytest.raises(InputError, match="placement"):
        placement_matrix(bad, 0.5, 0.4)


def test_unconverged_is_reported_and_strict_raises(cyl, mesh, caplog):
    with caplog.at_level(logging.WARNING, logger="airmat.design.relax"):
        res = relax_to_target(*mesh, cyl, max_iter=3, levels=0, progress=False)
    assert not res.converged and res.n_iter == 3 and "not converged" in res.message
    assert any("not converged" in r.message for r in caplog.records)
    with pytest.raises(ConvergenceError) as err:
        relax_to_target(*mesh, cyl, max_iter=3, levels=0, progress=False, strict=True)
    assert err.value.data["n_iter"] == 3


def test_divergence_raises(cyl, mesh, monkeypatch):
    real = MeshProjector.closest

    def broken(self, points):
        out = real(self, points)
        out.points[0] = np.nan
        return out

    monkeypatch.setattr(MeshProjector, "closest", broken)
    with pytest.raises(ConvergenceError, match="diverged"):
        relax_to_target(*mesh, cyl, levels=0, progress=False)


def test_umbrella_vanishes_on_flat_mattress(mesh):
    uv, faces = mesh
    lap = umbrella_operator(uv, faces)
    assert np.abs(lap @ uv).max() < 1e-12
    assert lap.shape[0] == len(uv) - 4        # every vertex but the four corners is smoothed
    assert np.allclose(np.asarray(lap.sum(axis=1)).ravel(), 0)   # rows: x_i minus a weighted mean


def test_mesh_spacing_does_not_change_the_result(cyl):
    """k_A2, k_A3 are scaled with the spacing: 25 and 12.5 mm meshes give the same Ŝ."""
    coarse = triangulate_mattress(MATTRESS, spacing=0.025)
    fine = triangulate_mattress(MATTRESS, spacing=0.0125)
    a = relax_to_target(*coarse, cyl, progress=False)
    b = relax_to_target(*fine, cyl, progress=False)
    # compare the positions of the coarse vertices (they are fine vertices too)
    dist, idx = cKDTree(fine[0]).query(coarse[0])
    assert dist.max() < 1e-12
    assert np.abs(b.xyz[idx] - a.xyz).max() < 1e-3


def test_candidate_placements_are_the_default_turned_about_its_normal(cyl):
    w, h = 0.5, 0.4
    cands = candidate_placements(Target.from_mesh(cyl), w, h)
    assert len(cands) == 4 and np.array_equal(cands[0], auto_placement(Target.from_mesh(cyl), w, h))
    centres = [c[:3, :3] @ [w / 2, h / 2, 0] + c[:3, 3] for c in cands]
    assert np.allclose(centres, centres[0], atol=1e-12)
    for k, c in enumerate(cands):
        assert np.allclose(c[:3, 2], cands[0][:3, 2], atol=1e-12)            # same top normal
        turn = np.arctan2(c[:3, 0] @ cands[0][:3, 1], c[:3, 0] @ cands[0][:3, 0])
        assert np.degrees(turn) % 360 == pytest.approx(90 * k, abs=1e-9)


def test_placement_turns_to_the_orientation_the_target_covers():
    """850 mm of arc, 760 mm of axis: the longest straight extent is the axis, but only the
    mattress's long side (830 mm) around the arc keeps it all on S."""
    surf = cylinder(0.3, length=0.76, arc=0.85, spacing=0.01)
    uv, faces = triangulate_mattress(Mattress(0.83, 0.74), spacing=0.04)
    default = auto_placement(Target.from_mesh(surf), 0.83, 0.74)
    assert abs(default[0, 0]) == pytest.approx(1, abs=1e-9)                 # u along the axis (x)
    res = relax_to_target(uv, faces, Target.from_mesh(surf), progress=False)
    assert abs(res.placement[1, 0]) == pytest.approx(1, abs=1e-9)           # u around the arc (y)
    assert res.converged and res.n_iter < 100 and not res.off_target.any()
    _, sigma = edge_sigma(res.xyz, uv, faces)
    assert np.abs(sigma - 1).max() < 2e-3
    # the default placement, relaxed rim-aware, overhangs the axis ends but is not strained
    turned_back = relax_to_target(uv, faces, Target.from_mesh(surf), placement=default, progress=False)
    assert turned_back.off_target.max() > 0.02
    assert np.abs(edge_sigma(turned_back.xyz, uv, faces)[1] - 1).max() < 5e-3


def test_a_covering_target_keeps_the_default_placement(relaxed, cyl):
    assert np.array_equal(relaxed.placement, auto_placement(Target.from_mesh(cyl), 0.5, 0.4))
    assert not relaxed.off_target.any()
