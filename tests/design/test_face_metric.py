"""Ŝ in the named face's metric (airmat.design.face_metric): exact ratios on a grid, one-signed designs
unchanged bit for bit, a saddle's Ŝ shortened where its named face carries strings, and the
check landing closer."""

import numpy as np
import pytest

from airmat.geometry.topology import mesh_edges
from airmat.synthetic.targets import cylinder, saddle
from airmat.design.constructibility import constructibility
from airmat.design.face_metric import face_metric, named_face
from airmat.design.mattress import Mattress, triangulate_mattress
from airmat.design.surface import approximate_surface

D = 0.07


@pytest.fixture(scope="module")
def grid():
    uv, faces = triangulate_mattress(Mattress(0.2, 0.16), spacing=0.02)
    return uv, faces, mesh_edges(faces)


def _edge_kind(uv, edges):
    d = np.abs(uv[edges[:, 1]] - uv[edges[:, 0]])
    return d[:, 1] < 1e-9, d[:, 0] < 1e-9            # along u, along v (the rest are diagonals)


def _field(n, k_u, k_v):
    kappa = np.tile([k_u, k_v], (n, 1))
    dirs = np.tile(np.array([[1.0, 0, 0], [0, 1.0, 0]]), (n, 1, 1))
    return kappa, dirs


def test_saddle_field_shortens_the_named_face_along_its_own_strings_only(grid):
    uv, faces, edges = grid
    xyz = np.column_stack([uv, np.zeros(len(uv))])
    kappa, dirs = _field(len(uv), 3.0, -1.4)          # bottom strings bend along u, top strings along v
    m = face_metric(xyz, uv, faces, kappa, dirs, thickness=D)
    along_u, along_v = _edge_kind(uv, edges)
    assert m.face == "top"
    np.testing.assert_allclose(m.ratio[along_u], 1.0, atol=1e-12)
    np.testing.assert_allclose(m.ratio[along_v], 1 / (1 + D * 1.4), rtol=1e-12)
    diag = ~(along_u | along_v)
    np.testing.assert_allclose(m.ratio[diag], 1 / (1 + D * 1.4 * 0.5), rtol=1e-12)   # cos² 45° = ½
    flat = np.linalg.norm(uv[edges[:, 1]] - uv[edges[:, 0]], axis=1)
    np.testing.assert_allclose(m.rest, flat * m.ratio, rtol=1e-12)
    assert m.summary() == {"face": "top", "min_ratio": pytest.approx(1 / (1 + D * 1.4))}


def test_the_named_face_follows_the_majority_sign(grid):
    uv, faces, _ = grid
    xyz = np.column_stack([uv, np.zeros(len(uv))])
    kappa, dirs = _field(len(uv), -3.0, 1.4)          # mirrored: top strings dominate
    m = face_metric(xyz, uv, faces, kappa, dirs, thickness=D)
    assert m.face == "bottom" and named_face(kappa, uv, faces) == "bottom"
    assert m.ratio.min() == pytest.approx(1 / (1 + D * 1.4))


@pytest.mark.parametrize("k_v", [0.0, 0.5, -0.2])
def test_no_minority_string_no_shortening(grid, k_v):
    """One sign, or a minority below kappa_min (0.25 1/m): the face keeps Ω's lengths exactly."""
    uv, faces, _ = grid
    xyz = np.column_stack([uv, np.zeros(len(uv))])
    kappa, dirs = _field(len(uv), 3.0, k_v)
    m = face_metric(xyz, uv, faces, kappa, dirs, thickness=D, kappa_min=0.25)
    assert m.flat and np.all(m.ratio == 1.0)


def test_constructibility_measures_sigma_against_the_metric(grid):
    uv, faces, edges = grid
    kappa, dirs = _field(len(uv), 3.0, -1.4)
    # a flat "Ŝ" squeezed along v as the top face's strings would squeeze it
    xyz = np.column_stack([uv[:, 0], uv[:, 1] / (1 + D * 1.4), np.zeros(len(uv))])
    m = face_metric(np.column_stack([uv, np.zeros(len(uv))]), uv, faces, kappa, dirs, thickness=D)
    plain = constructibility(xyz, uv, faces, kappa, sigma_band=(0.95, 1.05))
    metric = constructibility(xyz, uv, faces, kappa, sigma_band=(0.95, 1.05), metric=m)
    assert not plain.constructible and plain.sigma["min"] == pytest.approx(1 / (1 + D * 1.4), rel=1e-9)
    assert metric.constructible
    assert metric.sigma["min"] > 0.98 and metric.sigma["max"] < 1.03     # diagonals: cos² weighting vs exact
    assert metric.metric["face"] == "top" and plain.metric == {"face": "flat", "min_ratio": 1.0}


def test_a_one_signed_target_is_unchanged_bit_for_bit():
    surf = cylinder(0.3, length=0.9, arc=0.8, spacing=0.01)
    m = Mattress(0.6, 0.5)
    a = approximate_surface(surf, m, spacing=0.04, progress=False)
    b = approximate_surface(surf, m, spacing=0.04, progress=False, face_metric=False)
    assert np.array_equal(a.xyz, b.xyz)
    assert a.report.metric == {"face": "flat", "min_ratio": 1.0} and a.report.sigma == b.report.sigma


@pytest.fixture(scope="module")
def saddle_pair():
    surf = saddle(a=1 / 3.0, b=1 / 1.4, extent=(1.0, 0.9), spacing=0.01)     # |κ| 3 and 1.4 1/m
    m = Mattress(0.83, 0.74)
    return (approximate_surface(surf, m, spacing=0.04, progress=False),
            approximate_surface(surf, m, spacing=0.04, progress=False, face_metric=False))


def test_a_saddle_is_shortened_where_its_named_face_carries_strings(saddle_pair):
    metric, flat = saddle_pair
    # the placement decides which way Ŝ's top normal points, so which face carries the 3 1/m strings
    assert metric.report.metric["face"] == named_face(metric.curvature.kappa, metric.uv, metric.faces)
    assert metric.report.metric["face"] in ("top", "bottom") and flat.report.metric["face"] == "flat"
    assert metric.relax.converged and metric.report.constructible
    # σ against the face metric: a band no wider than σ against Ω in Ω's metric (0.968-1.082 measured;
    # the hyperbolic paraboloid is not developable)
    assert flat.report.sigma["min"] <= metric.report.sigma["min"] and metric.report.sigma["max"] <= flat.report.sigma["max"]
    edges = mesh_edges(metric.faces)
    along_u, along_v = _edge_kind(metric.uv, edges)
    length = lambda x: np.linalg.norm(x[edges[:, 1]] - x[edges[:, 0]], axis=1)
    flat_len = length(np.column_stack([metric.uv, np.zeros(len(metric.uv))]))
    inner = (np.abs(metric.uv - metric.uv.mean(axis=0)) < 0.2).all(axis=1)
    k2 = np.abs(np.median(metric.curvature.kappa[inner, 1]))
    inner_e = inner[edges].all(axis=1)
    # which Ω axis the negative curvature runs along depends on the placement: take the shorter one
    ratio = {ax: np.median(length(metric.xyz)[sel & inner_e] / flat_len[sel & inner_e])
             for ax, sel in (("u", along_u), ("v", along_v))}
    short = min(ratio.values())
    assert short == pytest.approx(1 / (1 + D * k2), abs=0.015)       # 0.904 measured
    assert max(ratio.values()) == pytest.approx(1.0, abs=0.03)       # 0.98: the saddle's stretch
    flat_ratio = min(np.median(length(flat.xyz)[sel & inner_e] / flat_len[sel & inner_e])
                     for sel in (along_u, along_v))
    assert flat_ratio > short + 0.03


@pytest.mark.slow
def test_the_saddle_preset_lands_closer_in_the_face_metric():
    """The check (top face vs Ŝ, 20 mm) of the saddle preset lands closer to Ŝ in the face metric.

    Closer is the promise; by how much is not: it depends on how many of the saddle's strings the shorter
    face moves, which no design argument gives (measured 2.59 -> 2.17 % of the diagonal, later 2.58 ->
    1.98 %). The open-loop check is deterministic to round-off (the mirror test in
    tests/inflation/test_inflation_physics.py: 1e-11 m), and the open loop moves smoothly with the lengths
    (their 0.01 mm rounding moves the face by about as much): a decrease beyond the 0.1 mm margin is the
    face metric's doing."""
    from airmat.check.inflation_check import check
    from airmat.design.pipeline import DesignParams, design
    from airmat.design.presets import preset

    target, mattress = preset("saddle")
    rms = {fm: check(design(target, mattress, params=DesignParams(face_metric=fm), progress=False),
                     envelope=False).runs["median"].deviation.rms for fm in (True, False)}
    assert rms[True] < rms[False] - 1e-4


def test_curvature_beyond_reach_shortens_only_as_much_as_a_string_can(grid):
    uv, faces, edges = grid
    xyz = np.column_stack([uv, np.zeros(len(uv))])
    kappa, dirs = _field(len(uv), 120.0, -90.0)        # the noise of a curvature fit at a rim, say
    m = face_metric(xyz, uv, faces, kappa, dirs, thickness=D, kappa_max=15.66)
    _, along_v = _edge_kind(uv, edges)
    np.testing.assert_allclose(m.ratio[along_v], 1 / (1 + D * 15.66), rtol=1e-12)


def test_no_string_within_the_margin_shortens_the_face(grid):
    uv, faces, edges = grid
    xyz = np.column_stack([uv, np.zeros(len(uv))])
    kappa, dirs = _field(len(uv), 3.0, -1.4)
    m = face_metric(xyz, uv, faces, kappa, dirs, thickness=D, margin=0.03)
    near = np.min(np.concatenate([uv - uv.min(axis=0), uv.max(axis=0) - uv], axis=1), axis=1) < 0.03
    _, along_v = _edge_kind(uv, edges)
    both_near, both_in = near[edges].all(axis=1), (~near[edges]).all(axis=1)
    np.testing.assert_array_equal(m.ratio[both_near], 1.0)
    np.testing.assert_allclose(m.ratio[along_v & both_in], 1 / (1 + D * 1.4), rtol=1e-12)
    assert (along_v & both_in).any() and both_near.any()
