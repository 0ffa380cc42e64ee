"""Table-1 figures and the constructibility verdict (airmat.design.constructibility), and Ω's mesh."""

import numpy as np
import pytest

from airmat.errors import InputError
from airmat.calib.model import kappa_max
from airmat.design.constructibility import PAPER_KAPPA_MAX, constructibility, edge_sigma
from airmat.design.mattress import Mattress, triangulate_mattress

M = Mattress(0.6, 0.5)


@pytest.fixture(scope="module")
def omega():
    return triangulate_mattress(M, spacing=0.05)


def test_flat_mattress_is_constructible(omega):
    uv, faces = omega
    xyz = np.column_stack([uv, np.zeros(len(uv))])
    rep = constructibility(xyz, uv, faces, np.zeros((len(uv), 2)))
    assert rep.constructible and rep.reasons == []
    assert rep.sigma == pytest.approx({"min": 1.0, "avg": 1.0, "max": 1.0})
    assert rep.kappa1 == {"avg": 0.0, "max": 0.0}


def test_default_kappa_max_is_the_papers_calibration():
    assert PAPER_KAPPA_MAX == pytest.approx(float(kappa_max(0.30, 0.018, 0.070)))
    assert PAPER_KAPPA_MAX == pytest.approx(15.66, abs=0.01)


def test_stretch_is_reported_with_its_place(omega):
    uv, faces = omega
    xyz = np.column_stack([uv, np.zeros(len(uv))])
    # stretch x by 15 % in the band 0.4 < u < 0.5 (m): σ = 1.15 on the edges there
    u = uv[:, 0]
    xyz[:, 0] = np.where(u > 0.4, 0.4 + 1.15 * (np.minimum(u, 0.5) - 0.4) + np.maximum(u - 0.5, 0), u)
    rep = constructibility(xyz, uv, faces, np.zeros((len(uv), 2)))
    assert not rep.constructible
    assert rep.sigma["max"] == pytest.approx(1.15)
    (reason,) = rep.reasons
    assert reason.startswith("σ = 1.150 at (4") and "mm on Ω" in reason and "stretch" in reason
    where = [float(t) for t in reason.split("(")[1].split(")")[0].split(",")]
    assert 400 <= where[0] <= 500                                    # mm, inside the stretched band


def test_contraction_and_curvature_beyond_reach(omega):
    uv, faces = omega
    xyz = np.column_stack([0.85 * uv, np.zeros(len(uv))])            # σ = 0.85 everywhere
    kappa = np.zeros((len(uv), 2))
    i = np.argmin(np.linalg.norm(uv - [0.2, 0.3], axis=1))
    kappa[i] = [-20.0, 3.0]
    rep = constructibility(xyz, uv, faces, kappa, sigma_band=(0.9, 1.02))
    assert not rep.constructible and len(rep.reasons) == 2
    assert "σ = 0.850" in rep.reasons[0] and "contract" in rep.reasons[0]
    assert rep.reasons[1].startswith("|κ| = 20.0 1/m at (200, 300) mm on Ω exceeds the reachable 15.66")
    assert rep.kappa1["max"] == 20.0 and rep.kappa2["max"] == 3.0
    # a band and a reach that allow it
    assert constructibility(xyz, uv, faces, kappa, sigma_band=(0.8, 1.1), kappa_max=25).constructible


def test_averages_are_area_weighted(omega):
    uv, faces = omega
    kappa = np.column_stack([np.full(len(uv), 2.0), np.where(uv[:, 0] < 0.3, 1.0, 0.0)])
    rep = constructibility(np.column_stack([uv, np.zeros(len(uv))]), uv, faces, kappa)
    assert rep.kappa1["avg"] == pytest.approx(2.0)
    assert 0.4 < rep.kappa2["avg"] < 0.6                              # half of Ω has |κ2| = 1


def test_edge_sigma_counts_each_edge_once(omega):
    uv, faces = omega
    edges, sigma = edge_sigma(np.column_stack([uv, np.zeros(len(uv))]), uv, faces)
    # Euler: V - E + F = 1 for a disc
    assert len(uv) - len(edges) + len(faces) == 1
    assert np.allclose(sigma, 1.0)


def test_triangulation_of_omega():
    uv, faces = triangulate_mattress(Mattress(0.83, 0.74), spacing=0.02)
    assert uv.min(axis=0) == pytest.approx([0, 0]) and uv.max(axis=0) == pytest.approx([0.83, 0.74])
    p = uv[faces]
    signed = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0])
    assert (signed > 0).all()                                         # counter-clockwise: top normal +z
    assert 0.5 * signed.sum() == pytest.approx(0.83 * 0.74)
    assert np.diff(np.unique(uv[:, 0])).max() <= 0.02 + 1e-12


@pytest.mark.parametrize("kw", [{"spacing": 0.0}, {"spacing": -1.0}, {"spacing": 0.8}, {"spacing": 1e-5}])
def test_triangulation_refuses_bad_spacing(kw):
    with pytest.raises(InputError, match="spacing"):
        triangulate_mattress(Mattress(0.83, 0.74), **kw)


@pytest.mark.parametrize("size", [(0.0, 1.0), (1.0, -2.0), (float("nan"), 1.0)])
def test_mattress_refuses_bad_sizes(size):
    with pytest.raises(InputError, match="mattress"):
        Mattress(*size)


def test_omega_off_the_target_is_a_warning_not_a_reason(omega):
    uv, faces = omega
    xyz = np.column_stack([uv, np.zeros(len(uv))])
    # the strip u > 0.5 m (the last 100 mm of 600) lies beyond the target's rim, by u - 0.5 m
    off = np.clip(uv[:, 0] - 0.5, 0, None)
    rep = constructibility(xyz, uv, faces, np.zeros((len(uv), 2)), off_target=off)
    assert rep.constructible and rep.reasons == []
    # the vertex columns u = 0.55 and 0.6 m are off: their areas are strips 50 and 25 mm wide
    assert rep.off_target["share"] == pytest.approx((0.05 + 0.025) / 0.6)
    assert rep.off_target["max"] == pytest.approx(0.1)
    assert len(rep.warnings) == 1
    assert "12.5 % of Ω lies beyond the target's rim, up to 100 mm at (600, " in rep.warnings[0]
    # nothing off the target (or not told): no warning
    for given in (np.zeros(len(uv)), None):
        rep = constructibility(xyz, uv, faces, np.zeros((len(uv), 2)), off_target=given)
        assert rep.off_target == {"share": 0.0, "max": 0.0} and rep.warnings == []
    with pytest.raises(InputError, match="off_target"):
        constructibility(xyz, uv, faces, np.zeros((len(uv), 2)), off_target=off[:-1])
