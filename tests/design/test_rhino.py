"""design.3dm / inflated.3dm: read back with rhino3dm (units, layers, objects, user text)."""

import numpy as np
import pytest

from airmat.design.export.rhino import FACE_FAMILIES, STRING_KEYS, lift_to_surface, write_3dm
from test_export import _cylinder_surface, _document

rhino3dm = pytest.importorskip("rhino3dm")


def _layers(model):
    return {model.Layers.FindIndex(i).FullPath: model.Layers.FindIndex(i) for i in range(len(model.Layers))}


def _by_layer(model):
    layers = {model.Layers.FindIndex(i).Index: model.Layers.FindIndex(i).FullPath for i in range(len(model.Layers))}
    out = {}
    for obj in model.Objects:
        out.setdefault(layers[obj.Attributes.LayerIndex], []).append(obj)
    return out


@pytest.fixture(scope="module")
def design_3dm(tmp_path_factory):
    doc, _ = _document()
    xyz, uv, faces = _cylinder_surface()
    path = tmp_path_factory.mktemp("rhino") / "design.3dm"
    write_3dm(path, doc, xyz, uv, faces)
    return doc, (xyz, uv, faces), rhino3dm.File3dm.Read(str(path))


def test_units_layers_and_counts(design_3dm):
    doc, (xyz, uv, faces), model = design_3dm
    assert model.Settings.ModelUnitSystem == rhino3dm.UnitSystem.Millimeters
    layers = _layers(model)
    for ff in FACE_FAMILIES:
        assert f"omega::{ff}" in layers and f"S_hat::{ff}" in layers
    objs = _by_layer(model)
    n = len(doc["dashes"])
    assert n > 4
    for parent in ("omega", "S_hat"):
        assert sum(len(objs.get(f"{parent}::{ff}", [])) for ff in FACE_FAMILIES) == n
        assert len(objs[f"{parent}::ties"]) == 2 * n
    mesh = objs["S_hat"][0].Geometry
    assert len(mesh.Vertices) == len(xyz) and mesh.Faces.Count == len(faces)
    np.testing.assert_allclose(mesh.Vertices[7].X, xyz[7, 0] * 1000, atol=1e-3)
    assert "inflated" not in layers


def test_user_text_matches_design_json(design_3dm):
    doc, _, model = design_3dm
    objs = _by_layer(model)
    dash = doc["dashes"][0]
    key = f"{dash['side']}/{dash['family']}"
    curve = next(o for o in objs[f"omega::{key}"] if o.Attributes.Name == dash["id"])
    text = dict(curve.Attributes.GetUserStrings())
    assert set(STRING_KEYS) <= set(text)
    assert float(text["l_median_mm"]) == pytest.approx(dash["l_mm"]["median"])
    assert float(text["l_hi95_mm"]) == pytest.approx(dash["l_mm"]["hi95"])
    assert float(text["kappa_per_m"]) == pytest.approx(dash["kappa_per_m"])
    assert text["face"] == dash["side"] and text["family"] == dash["family"]
    start = curve.Geometry.PointAtStart
    assert (start.X, start.Y, start.Z) == pytest.approx((*dash["polyline_mm"][0], 0.0), abs=1e-6)


def test_lifted_strings_and_ties_lie_on_their_face(design_3dm):
    doc, _, model = design_3dm
    radius_mm, half = 400.0, doc["mattress"]["thickness_mm"] / 2
    # Ŝ is the cylinder x² + (z + R)² = R² (the mid-surface), its top normal pointing away from the axis:
    # the top face is the cylinder of radius R + t/2, the bottom face R - t/2
    face_radius = {"top": radius_mm + half, "bottom": radius_mm - half}
    objs = _by_layer(model)
    seen = set()
    for ff in FACE_FAMILIES:
        face = ff.split("/")[0]
        for o in objs.get(f"S_hat::{ff}", []):
            seen.add(face)
            pts = [o.Geometry.Point(i) for i in range(o.Geometry.PointCount)]
            r = np.array([np.hypot(p.X, p.Z + radius_mm) for p in pts])
            # up to the chord error of 50 mm facets (0.8 mm at R = 400 mm)
            np.testing.assert_allclose(r, face_radius[face], atol=1.0)
    assert seen == {"top", "bottom"}                    # the saddle has strings on both faces
    sides = {d["id"]: d["side"] for d in doc["dashes"]}
    ties = objs["S_hat::ties"]
    for o in ties:
        p = o.Geometry.Location
        face = sides[o.Attributes.GetUserString("id")]
        assert np.hypot(p.X, p.Z + radius_mm) == pytest.approx(face_radius[face], abs=1.0)


def test_lift_to_surface_is_exact_on_vertices_and_linear_inside():
    xyz, uv, faces = _cylinder_surface()
    # points on the edge of Ω are moved inside by 1e-9 of its diagonal (~1 m) first
    np.testing.assert_allclose(lift_to_surface(uv, xyz, uv, faces), xyz, atol=1e-8)
    mid = 0.5 * (uv[faces[:, 0]] + uv[faces[:, 1]])
    np.testing.assert_allclose(lift_to_surface(mid, xyz, uv, faces),
                               0.5 * (xyz[faces[:, 0]] + xyz[faces[:, 1]]), atol=1e-8)


def test_inflated_shapes_on_hidden_layers(tmp_path):
    doc, _ = _document()
    xyz, uv, faces = _cylinder_surface()
    shapes = {"median": xyz + 0.001, "lo95": xyz, "hi95": xyz - 0.001}
    write_3dm(tmp_path / "inflated.3dm", doc, xyz, uv, faces, shapes=shapes)
    model = rhino3dm.File3dm.Read(str(tmp_path / "inflated.3dm"))
    layers = _layers(model)
    assert layers["inflated::median"].Visible
    assert not layers["inflated::lo95"].Visible and not layers["inflated::hi95"].Visible
    objs = _by_layer(model)
    med = objs["inflated::median"][0].Geometry
    assert len(med.Vertices) == len(xyz)
    assert med.Vertices[0].Z == pytest.approx((xyz[0, 2] + 0.001) * 1000, abs=1e-3)


def test_monte_carlo_band_on_a_hidden_layer_with_vertex_colours(tmp_path, design_3dm):
    from airmat.design.export.rhino import band_colours

    doc, _ = _document()
    xyz, uv, faces = _cylinder_surface()
    band = np.linspace(0.002, 0.012, len(xyz))                      # m: 2 .. 12 mm
    write_3dm(tmp_path / "inflated.3dm", doc, xyz, uv, faces, shapes={"median": xyz}, band=band)
    model = rhino3dm.File3dm.Read(str(tmp_path / "inflated.3dm"))
    layers = _layers(model)
    assert not layers["monte_carlo::p95"].Visible
    (obj,) = _by_layer(model)["monte_carlo::p95"]
    mesh = obj.Geometry
    assert len(mesh.Vertices) == len(xyz) and mesh.VertexColors.Count == len(xyz)
    got = np.array([tuple(mesh.VertexColors[i])[:3] for i in range(len(xyz))])
    want, lo, hi = band_colours(band * 1000)
    np.testing.assert_array_equal(got, want)
    assert got[0].tolist() == [68, 1, 84] and got[-1].tolist() == [253, 231, 37]   # viridis ends
    text = dict(obj.Attributes.GetUserStrings())
    assert float(text["colour_low_mm"]) == pytest.approx(2.0) and float(text["colour_high_mm"]) == pytest.approx(12.0)
    assert text["colour_low_rgb"] == "68,1,84" and text["colour_high_rgb"] == "253,231,37"
    # without a band: no such layer
    assert not any(k.startswith("monte_carlo") for k in _layers(design_3dm[2]))


def test_band_colours_of_constant_values_are_the_low_end():
    from airmat.design.export.rhino import band_colours

    c, lo, hi = band_colours(np.full(4, 3.0))
    assert (lo, hi) == (3.0, 3.0) and c.tolist() == [[68, 1, 84]] * 4
