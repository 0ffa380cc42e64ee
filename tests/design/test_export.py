"""Workshop files: they open with their own readers, agree with design.json, and are reproducible."""

import csv
import json
import xml.etree.ElementTree as ET

import ezdxf
import numpy as np
import pytest

from analytic_fields import grid_uv, saddle_field
from airmat.design.calibration_source import default_calibration
from airmat.design.export import (design_document, read_design_json, write_cutting_list, write_design_json,
                           write_dxf, write_preview, write_svg)
from airmat.design.export.preview import face_sigma, preview_figure
from airmat.design.export.dxf import GAP_MM
from airmat.design.export.svg import LAYOUT, svg_transform
from airmat.design.mattress import Mattress
from airmat.design.string_lengths import string_pattern
from airmat.design.stripes import StripeParams, trace_stripes

MATTRESS = Mattress(0.83, 0.74, 0.07)
REPORT = {"sigma": {"min": 0.99, "avg": 1.0, "max": 1.01}, "kappa1_per_m": {"avg": 3.0, "max": 3.0},
          "kappa2_per_m": {"avg": 1.8, "max": 1.8}, "constructible": True, "reasons": []}
SVG = "{http://www.w3.org/2000/svg}"


def _cylinder_surface(radius=0.4):
    """Ŝ: Ω rolled onto a cylinder of radius ``radius`` about the v axis (isometric: σ = 1)."""
    uv = grid_uv(MATTRESS.width, MATTRESS.height, 0.05)
    nu = len(np.unique(uv[:, 0]))
    nv = len(uv) // nu
    i, j = np.meshgrid(np.arange(nu - 1), np.arange(nv - 1))
    a = (j * nu + i).ravel()
    faces = np.concatenate([np.column_stack([a, a + 1, a + nu + 1]), np.column_stack([a, a + nu + 1, a + nu])])
    t = uv[:, 0] / radius
    xyz = np.column_stack([radius * np.sin(t), uv[:, 1], radius * (np.cos(t) - 1.0)])
    return xyz, uv, faces


def _document(seed=0):
    mf = saddle_field(kappa=3.0)
    stripes = trace_stripes(mf, StripeParams())
    cal = default_calibration(seed=seed, n_samples=400)
    pattern = string_pattern(mf, stripes.dashes, cal, L=0.3, notes=stripes.notes)
    return design_document(pattern, mattress=MATTRESS, calibration=cal, report=REPORT,
                           parameters={"L_mm": 300.0}, seed=seed, name="saddle-test"), pattern


def _write_all(folder, doc):
    folder.mkdir(parents=True, exist_ok=True)
    write_design_json(folder / "design.json", doc)
    write_svg(folder / "pattern.svg", doc)
    write_dxf(folder / "pattern.dxf", doc)
    write_cutting_list(folder / "cutting_list.csv", doc)
    write_preview(folder / "preview.png", doc, *_cylinder_surface(), dpi=40)
    return folder


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    doc, pattern = _document()
    return _write_all(tmp_path_factory.mktemp("design"), doc), doc, pattern


def test_design_json_round_trips_and_describes_every_string(written):
    folder, doc, pattern = written
    back = read_design_json(folder / "design.json")
    assert back == json.loads(json.dumps(doc))
    assert back["uncalibrated"] is True and back["calibration"]["uncalibrated"] is True
    assert len(back["dashes"]) == len(pattern.strings) > 0
    assert {d["side"] for d in back["dashes"]} == {"top", "bottom"}
    for d, s in zip(back["dashes"], pattern.strings):
        assert d["id"] == s.dash.id
        np.testing.assert_allclose(np.array(d["polyline_mm"]) * 1e-3, s.dash.polyline, atol=0.006e-3)
        assert d["a_mm"] == d["polyline_mm"][0] and d["b_mm"] == d["polyline_mm"][-1]
        assert d["L_mm"] == pytest.approx(300.0, abs=0.01)
        assert d["l_mm"]["lo95"] <= d["l_mm"]["median"] <= d["l_mm"]["hi95"]
        assert d["l_mm"]["median"] == pytest.approx(s.l_median * 1e3, abs=0.006)
        assert (d["kappa_per_m"] < 0) == (d["side"] == "top")
    strings = back["summary"]["strings"]
    assert sum(strings[f][k] for f in strings for k in strings[f]) == len(back["dashes"])


def test_svg_is_1_to_1_mm_and_agrees_with_the_json(written):
    folder, doc, _ = written
    root = ET.parse(folder / "pattern.svg").getroot()
    W, H = doc["mattress"]["width_mm"], doc["mattress"]["height_mm"]
    w_mm, h_mm = float(root.get("width")[:-2]), float(root.get("height")[:-2])
    assert root.get("width").endswith("mm") and root.get("height").endswith("mm")
    assert [float(x) for x in root.get("viewBox").split()] == [0.0, 0.0, w_mm, h_mm]
    assert w_mm > 2 * W and h_mm > H
    text = " ".join(t.text or "" for t in root.iter(f"{SVG}text"))
    assert "UNCALIBRATED" in text and "saddle-test" in text and "mirrored" in text
    groups = {g.get("id"): g for g in root.iter(f"{SVG}g")}
    for d in doc["dashes"]:
        g = groups[d["id"]]
        pts = np.array([[float(c) for c in p.split(",")] for p in g.find(f"{SVG}polyline").get("points").split()])
        poly = np.array(d["polyline_mm"])
        x, y = svg_transform(d["side"], poly[:, 0], poly[:, 1], W, H)
        np.testing.assert_allclose(pts, np.column_stack([x, y]), atol=0.006)
        label = [t for t in g.iter(f"{SVG}text")]
        assert [t.text for t in label] == [f"{d['id']}  l={d['l_mm']['median']:.1f}"]
        # beside the string, not on it: the anchor is off every segment by about half the font size
        p = np.array([float(label[0].get("x")), float(label[0].get("y"))])
        a, b = pts[:-1], pts[1:]
        t = np.clip(np.einsum("ij,ij->i", p - a, b - a) / np.maximum(np.einsum("ij,ij->i", b - a, b - a), 1e-12), 0, 1)
        dist = np.linalg.norm(a + t[:, None] * (b - a) - p, axis=1).min()
        assert 0.5 * LAYOUT["font"] <= dist <= 0.7 * LAYOUT["font"]
    # every text fits on the page (width estimated at 0.6 font sizes per character)
    for t in root.iter(f"{SVG}text"):
        x, size, n = float(t.get("x")), float(t.get("font-size")), len(t.text or "")
        if t.get("transform"):
            continue        # the string labels, checked above to sit beside their strings inside the faces
        start = {"start": x, "middle": x - 0.3 * size * n, "end": x - 0.6 * size * n}[t.get("text-anchor")]
        assert 0 <= start and start + 0.6 * size * n <= w_mm, t.text
        assert size <= float(t.get("y")) <= h_mm, t.text
    bar = groups["scale-bar"].find(f"{SVG}line")
    assert float(bar.get("x2")) - float(bar.get("x1")) == pytest.approx(100.0)
    # the bottom face is mirrored: u = 0 lies at its right edge
    x0, _ = svg_transform("bottom", 0.0, 0.0, W, H)
    xW, _ = svg_transform("bottom", W, 0.0, W, H)
    assert x0 - xW == pytest.approx(W)


def test_dxf_reopens_in_mm_with_a_layer_per_face_and_family(written):
    folder, doc, _ = written
    dxf = ezdxf.readfile(folder / "pattern.dxf")
    assert dxf.units == ezdxf.units.MM and dxf.header["$INSUNITS"] == ezdxf.units.MM
    layers = {layer.dxf.name for layer in dxf.layers}
    assert {"TOP_K1", "TOP_K2", "BOTTOM_K1", "BOTTOM_K2", "OUTLINE", "TIES"} <= layers
    msp = dxf.modelspace()
    texts = {t.dxf.text.split("  ")[0]: t for t in msp.query("TEXT")}
    polys = [p for p in msp.query("LWPOLYLINE") if p.dxf.layer != "OUTLINE"]
    assert len(polys) == len(doc["dashes"])
    assert {d["side"] for d in doc["dashes"]} == {"top", "bottom"}
    ties = np.array([(c.dxf.center.x, c.dxf.center.y) for c in msp.query("CIRCLE") if c.dxf.layer == "TIES"])
    assert len(ties) == 2 * len(doc["dashes"])
    by_face = [d for face in ("top", "bottom") for d in doc["dashes"] if d["side"] == face]
    for p, d in zip(polys, by_face):
        layer = f"{d['side'].upper()}_{d['family'].upper()}"
        assert p.dxf.layer == layer and texts[d["id"]].dxf.layer == layer
        # the string's length to cut is written beside it
        assert texts[d["id"]].dxf.text == f"{d['id']}  l={d['l_mm']['median']:.1f} mm"
        u, v = np.array(d["polyline_mm"]).T
        # top face as seen from above (Ω itself), bottom face mirrored to the right of it
        x = u if d["side"] == "top" else 2 * 830 + GAP_MM - u
        np.testing.assert_allclose(np.array(p.get_points("xy")), np.column_stack([x, v]), atol=1e-9)
        for end in (np.array([x[0], v[0]]), np.array([x[-1], v[-1]])):
            assert np.min(np.linalg.norm(ties - end, axis=1)) < 1e-9
    outlines = [np.array(p.get_points("xy")) for p in msp.query("LWPOLYLINE") if p.dxf.layer == "OUTLINE"]
    np.testing.assert_allclose(outlines[0], [[0, 0], [830, 0], [830, 740], [0, 740]])
    np.testing.assert_allclose(outlines[1], [[910, 0], [1740, 0], [1740, 740], [910, 740]])
    labels = [t.dxf.text for t in msp.query("TEXT") if t.dxf.layer == "OUTLINE"]
    assert "BOTTOM face, seen from below (mirrored)" in labels and "TOP face, seen from above" in labels


def test_dxf_header_extents_and_audit(written):
    folder, _, _ = written
    dxf = ezdxf.readfile(folder / "pattern.dxf")
    lo, hi = np.array(dxf.header["$EXTMIN"]), np.array(dxf.header["$EXTMAX"])
    # the two faces side by side, their labels above and the origin labels below
    assert lo[0] <= 0 and lo[1] < 0 and 1740 <= hi[0] < 1800 and 740 < hi[1] < 820
    assert np.all(np.abs(np.concatenate([lo, hi])) < 1e4)
    auditor = dxf.audit()
    assert not auditor.has_errors, [e.message for e in auditor.errors]


def test_dxf_is_byte_stable_across_hash_seeds(tmp_path):
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    script = ("import sys; sys.path[:0] = [sys.argv[2], sys.argv[3]]\n"
              "from test_export import _document\n"
              "from airmat.design.export.dxf import write_dxf\n"
              "write_dxf(sys.argv[1], _document()[0])\n")
    data = []
    for seed in ("1", "10"):     # seeds 1 and 10 give ezdxf's CLASSES different orders unless write_dxf sorts them
        out = tmp_path / f"h{seed}.dxf"
        env = {**os.environ, "PYTHONHASHSEED": seed}
        subprocess.run([sys.executable, "-c", script, str(out), str(root), str(root / "tests" / "design")],
                       check=True, env=env, cwd=tmp_path)
        data.append(out.read_bytes())
    assert data[0] == data[1]


def test_cutting_list_is_sorted_for_the_workshop_and_agrees(written):
    folder, doc, _ = written
    with open(folder / "cutting_list.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == len(doc["dashes"])
    keys = [(r["face"], r["family"], r["id"]) for r in rows]
    assert keys == sorted(keys)
    by_id = {d["id"]: d for d in doc["dashes"]}
    for r in rows:
        d = by_id[r["id"]]
        assert r["face"] == d["side"] and r["family"] == d["family"]
        assert float(r["l_median_mm"]) == pytest.approx(d["l_mm"]["median"], abs=0.005)
        assert float(r["l_lo95_mm"]) == pytest.approx(d["l_mm"]["lo95"], abs=0.005)
        assert float(r["l_hi95_mm"]) == pytest.approx(d["l_mm"]["hi95"], abs=0.005)
        assert float(r["kappa_per_m"]) == pytest.approx(d["kappa_per_m"], abs=5e-5)
        assert float(r["L_mm"]) == pytest.approx(d["L_mm"], abs=0.005)


def test_preview_is_a_png_and_sigma_of_an_isometric_roll_is_one(written):
    folder, _, _ = written
    assert (folder / "preview.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    xyz, uv, faces = _cylinder_surface()
    sigma = face_sigma(xyz, uv, faces)
    # chords of a circle of radius R over an arc h are shorter by about h^2 / (24 R^2)
    assert np.all(np.abs(sigma - 1.0) < 0.05 ** 2 / (24 * 0.4 ** 2) * 1.01)


def test_same_design_gives_byte_identical_files(tmp_path, written):
    folder, _, _ = written
    doc, _ = _document()
    again = _write_all(tmp_path / "again", doc)
    for name in ("design.json", "pattern.svg", "pattern.dxf", "cutting_list.csv", "preview.png"):
        assert (again / name).read_bytes() == (folder / name).read_bytes(), name


def test_other_seed_changes_only_the_tolerances(tmp_path, written):
    _, doc, _ = written
    other, _ = _document(seed=1)
    assert [d["polyline_mm"] for d in other["dashes"]] == [d["polyline_mm"] for d in doc["dashes"]]
    assert [d["l_mm"] for d in other["dashes"]] != [d["l_mm"] for d in doc["dashes"]]


def test_preview_figure_is_the_figure_write_preview_saves(written, tmp_path):
    import io

    from matplotlib.figure import Figure

    folder, doc, _ = written
    fig = preview_figure(doc, *_cylinder_surface())
    assert isinstance(fig, Figure)
    assert fig.get_suptitle().startswith("airmat design: saddle-test")
    assert sum(ax.name == "3d" for ax in fig.axes) == 1 and len(fig.axes) == 4   # two panels, two colour bars
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=40)
    assert buf.getvalue() == (folder / "preview.png").read_bytes()



def test_preview_names_every_string_and_its_sigma_scale_holds_the_report(written):
    from matplotlib.collections import LineCollection

    from airmat.design.export.preview import id_font_size, sigma_limits

    _, doc, _ = written
    rep = {**doc["report"], "sigma": {"min": 0.955, "avg": 1.0, "max": 1.01}}
    fig = preview_figure({**doc, "report": rep}, *_cylinder_surface())
    pattern = fig.axes[0]
    ids = [t.get_text() for t in pattern.texts]
    assert sorted(ids) == sorted(d["id"] for d in doc["dashes"])
    # strings drawn thick and dark-outlined, the bottom face dashed (not dotted)
    lcs = [c for c in pattern.collections if isinstance(c, LineCollection)]
    assert all(lc.get_linewidths()[0] >= 2.5 and lc.get_path_effects() for lc in lcs)
    surface_bar = fig.axes[3]
    lo, hi = surface_bar.get_ylim()
    assert lo <= 0.955 and hi >= 1.045 - 1e-9
    assert sigma_limits(np.array([1.0]), {"sigma": {"min": 0.955, "max": 1.0}}) == (0.955, 1.045)
    # legible at the large presets' 150 strings and more: crowded ids are dropped, not shrunk below 6.5 pt
    assert id_font_size(20) == 8.0 and id_font_size(150) == 6.5 and id_font_size(500) == 6.5


def _crowded_document(n_u=24, n_v=24):
    """The test document with n_u * n_v short dashes on a grid, far more than their ids have room for."""
    doc, _ = _document()
    u = np.linspace(40.0, 790.0, n_u)
    v = np.linspace(40.0, 660.0, n_v)
    dashes = [{"id": f"k{1 + (j % 2)}-{i + 1:03d}-{j + 1:02d}", "side": ("top", "bottom")[(i + j) % 2],
               "family": "k1", "l_mm": {"median": 200.0 + i + j},
               "polyline_mm": [[float(u[i]), float(v[j])], [float(u[i]) + 25.0, float(v[j]) + 4.0]]}
              for i in range(n_u) for j in range(n_v)]
    return {**doc, "dashes": dashes}


def test_preview_at_many_strings_draws_no_two_ids_over_each_other():
    doc = _crowded_document()
    n = len(doc["dashes"])
    fig = preview_figure(doc, *_cylinder_surface())
    fig.canvas.draw()
    pattern = fig.axes[0]
    renderer = fig.canvas.get_renderer()
    texts = [t for t in pattern.texts if (t.get_gid() or "").startswith("id-")]
    boxes = np.array([t.get_window_extent(renderer).extents for t in texts])
    assert 20 < len(texts) < n           # the crowd is thinned, not emptied
    lo, hi = boxes[:, :2], boxes[:, 2:]
    overlap = np.all((lo[:, None] < hi[None]) & (lo[None] < hi[:, None]), axis=2)
    np.fill_diagonal(overlap, False)
    assert not overlap.any()
    frame = pattern.get_window_extent(renderer).extents
    assert np.all(lo >= frame[:2] - 0.5) and np.all(hi <= frame[2:] + 0.5)
    assert f"ids of {len(texts)} of {n} strings" in pattern.get_title()
    # each shown id names a string of the design, once
    ids = [t.get_text() for t in texts]
    assert len(set(ids)) == len(ids) and set(ids) <= {d["id"] for d in doc["dashes"]}
