"""airmat.design.free_face: each string's free face on Ŝ, against exact cylinders, planes and rigid motions;
Equation 3 at that span in the design, the design folder and the Monte-Carlo draws."""

import numpy as np
import pytest
from scipy.spatial import Delaunay
from scipy.spatial.transform import Rotation

from airmat.calib.model import kappa1
from airmat.synthetic.targets import saddle
from airmat.design.calibration_source import CalibrationSource
from airmat.design.free_face import free_face_ratio
from airmat.design.mattress import Mattress
from airmat.design.pipeline import DesignParams, design

D = 0.07


def _grid(w=0.6, h=0.4, n=(31, 21)):
    u, v = np.meshgrid(np.linspace(0, w, n[0]), np.linspace(0, h, n[1]))
    uv = np.column_stack([u.ravel(), v.ravel()])
    tri = Delaunay(uv).simplices
    e1, e2 = uv[tri[:, 1]] - uv[tri[:, 0]], uv[tri[:, 2]] - uv[tri[:, 0]]
    flip = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] < 0
    tri[flip] = tri[flip][:, ::-1]                      # counter-clockwise on Ω
    return uv, tri


ALONG_U = np.array([[0.15, 0.2], [0.3, 0.2], [0.45, 0.2]])
ALONG_V = np.array([[0.3, 0.05], [0.3, 0.35]])


@pytest.mark.parametrize("R", [0.4, 0.8])
def test_a_cylinder_gives_each_face_its_radius(R):
    """Ŝ bends away from the top face with radius R along u: the top face (Ŝ) keeps its length,
    the bottom face lies d inside, (R - d) / R; along the axis both keep it."""
    uv, tri = _grid()
    xyz = np.column_stack([R * np.sin(uv[:, 0] / R), uv[:, 1], R * np.cos(uv[:, 0] / R)])
    c = free_face_ratio(xyz, uv, tri, [ALONG_U, ALONG_U, ALONG_V, ALONG_V], ["bottom", "top", "bottom", "top"],
                        named="top", thickness=D)
    np.testing.assert_allclose(c, [1.0, 1 - D / R, 1.0, 1.0], atol=2e-3)
    # Ŝ standing for the bottom face: the top face lies d outside it
    c = free_face_ratio(xyz, uv, tri, [ALONG_U, ALONG_U], ["bottom", "top"], named="bottom", thickness=D)
    np.testing.assert_allclose(c, [1 + D / R, 1.0], atol=2e-3)


def test_an_in_plane_compression_is_read_along_the_dash_and_rigid_motions_change_nothing():
    uv, tri = _grid()
    xyz = np.column_stack([0.97 * uv[:, 0], uv[:, 1], np.zeros(len(uv))])
    moved = Rotation.from_rotvec([0.3, -0.2, 1.1]).apply(xyz) + [1.0, -2.0, 0.5]
    for surf in (xyz, moved):
        c = free_face_ratio(surf, uv, tri, [ALONG_U, ALONG_V], ["bottom", "top"], named="top", thickness=D)
        np.testing.assert_allclose(c, [0.97, 1.0], atol=1e-12)


def test_bad_arguments_are_refused():
    uv, tri = _grid()
    xyz = np.column_stack([uv, np.zeros(len(uv))])
    with pytest.raises(ValueError, match="named"):
        free_face_ratio(xyz, uv, tri, [ALONG_U], ["top"], named="mid", thickness=D)
    with pytest.raises(ValueError, match="n_points"):
        free_face_ratio(xyz, uv, tri, [ALONG_U], ["top"], named="top", thickness=D, n_points=1)
    assert free_face_ratio(xyz, uv, tri, [], [], named="top", thickness=D).shape == (0,)


POINT = CalibrationSource(L=0.3, delta=np.array([0.018]), d=np.array([0.070]), source="test",
                          uncalibrated=True, label="paper point values")


@pytest.fixture(scope="module")
def saddle_designs():
    surf = saddle(a=1 / 3.0, b=1 / 1.4, extent=(1.0, 0.9), spacing=0.01)     # |κ| 3 and 1.4 1/m
    m = Mattress(0.83, 0.74)
    return {ff: design(surf, m, calibration=POINT, params=DesignParams(spacing=0.04, free_face_span=ff),
                       progress=False) for ff in (True, False)}


def test_a_saddle_shortens_the_strings_whose_free_face_it_compresses(saddle_designs):
    on, off = saddle_designs[True], saddle_designs[False]
    assert [s.dash.id for s in on.pattern.strings] == [s.dash.id for s in off.pattern.strings]
    named = on.approx.report.metric["face"]
    for a, b in zip(on.pattern.strings, off.pattern.strings):
        assert b.free_span is None and b.eq3_span == b.dash.length
        assert a.free_span <= a.dash.length                       # a free face is never stretched
        # Equation 3 at the free face's span, exactly; never a longer string than the paper's
        assert kappa1(a.l_median, a.eq3_span, 0.018, 0.070) == pytest.approx(abs(a.kappa), rel=1e-9)
        assert a.l_median <= b.l_median + 1e-12
    # the minority family's strings sit on the named face: their free face is the other face, d from Ŝ,
    # which the saddle's middle compresses (the named face there is shorter than its strings make it)
    minority = [a for a in on.pattern.strings if a.side == named]
    ratios = np.array([a.free_span / a.dash.length for a in minority])
    assert minority and ratios.min() < 0.99                      # a real compression somewhere
    shorter = np.array([b.l_median - a.l_median for a, b in zip(on.pattern.strings, off.pattern.strings)])
    assert shorter.max() > 0.002                                  # by millimetres, not round-off


def test_the_free_span_is_written_and_read_back(saddle_designs, tmp_path):
    from airmat.design.design_io import read_design, write_design

    on = saddle_designs[True]
    doc = write_design(on, tmp_path / "d")
    assert all(d["free_span_mm"] is not None for d in doc["dashes"])
    back = read_design(tmp_path / "d")
    assert back.params.free_face_span is True
    for a, b in zip(on.pattern.strings, back.pattern.strings):
        assert b.free_span == pytest.approx(a.free_span, abs=0.006e-3)



@pytest.mark.parametrize("bad", [0.0, -5.0, 400.0])
def test_a_free_span_outside_its_dash_is_refused_naming_the_file(saddle_designs, tmp_path, bad):
    import json

    from airmat.errors import InputError
    from airmat.design.design_io import read_design, write_design

    write_design(saddle_designs[True], tmp_path / "d")
    path = tmp_path / "d" / "design.json"
    doc = json.loads(path.read_text())
    doc["dashes"][0]["free_span_mm"] = bad
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError, match="free_span_mm must be in") as err:
        read_design(tmp_path / "d")
    assert "design.json" in str(err.value.path)


def test_monte_carlo_draws_use_the_span_each_length_came_from(saddle_designs):
    """With one posterior point and no scatter, the draws' median κ is each string's own κ only when
    Equation 3 is inverted at the span its length came from."""
    from airmat.check.monte_carlo import draw

    on = saddle_designs[True]
    dr = draw(on, 3, seed=0)
    np.testing.assert_allclose(dr.kappa_median, [abs(s.kappa) for s in on.pattern.strings], rtol=1e-9)


@pytest.mark.slow
def test_the_saddle_preset_lands_closer_with_the_free_face_span():
    """The check (top face vs Ŝ, 20 mm) of the saddle preset lands closer to Ŝ with Equation 3 inverted at
    the free face's span than at the dash's.

    Closer is the promise; by how much is not: it depends on how much the free face's spans differ from
    the dashes' on this saddle, which no design argument gives (measured 23.4 -> 21.2 mm RMS). The
    open-loop check is deterministic to round-off (the mirror test in
    tests/inflation/test_inflation_physics.py: 1e-11 m), and the open loop moves smoothly with the lengths
    (their 0.01 mm rounding moves the face by about as much): a decrease beyond the 0.1 mm margin is the
    free face span's doing."""
    from airmat.check.inflation_check import check
    from airmat.design.presets import preset

    target, mattress = preset("saddle")
    rms = {ff: check(design(target, mattress, params=DesignParams(free_face_span=ff), progress=False),
                     envelope=False).runs["median"].deviation.rms for ff in (True, False)}
    assert rms[True] < rms[False] - 1e-4
