"""report.html tells the truth: each RMS names its surface and is that surface's number in inflate.json; the
verdict card; the deviation map on Ω first; the calibration beside its truth."""

import dataclasses
import json
import re
from html import unescape

import numpy as np
import pytest

from airmat.check.report import check_dict
from airmat.report.page import report_html

SURFACE = {"top": "top face", "bottom": "bottom face", "mid": "mid-surface"}


def named(checked, face):
    """The check as if Ŝ stood for ``face``: each run's ``deviation`` is that face's (as check(surface=face))."""
    runs = {k: dataclasses.replace(r, deviation=r.deviations[face]) for k, r in checked.runs.items()}
    return dataclasses.replace(checked, surface=face, runs=runs)


def plotly_figures(html: str) -> dict:
    """div id -> (data, layout) of every Plotly.newPlot on the page."""
    out = {}
    for m in re.finditer(r'Plotly\.newPlot\("([^"]+)",(.*?)\);</script>', html, flags=re.S):
        dec = json.JSONDecoder()
        data, end = dec.raw_decode(m.group(2))
        layout, _ = dec.raw_decode(m.group(2)[end + 1:])
        out[m.group(1)] = (data, layout)
    return out


def table(html: str, table_id: str) -> list:
    """Rows (header first) of the table with that id, as lists of cell texts."""
    body = html[html.index(f'id="{table_id}"'):].split("</table>")[0]
    return [re.findall(r"<t[hd]>(.*?)</t[hd]>", row) for row in re.findall(r"<tr>(.*?)</tr>", body)]


@pytest.mark.parametrize("face", ["top", "bottom", "mid"])
def test_every_labelled_rms_is_the_number_of_the_surface_it_names(run_objects, face):
    _, _, checked = run_objects
    chk = named(checked, face)
    doc = check_dict(chk)                      # inflate.json
    assert doc["surface"] == face
    rms = {k: v["rms_mm"] for k, v in doc["deviation"]["surfaces"].items()}
    runs = {"median": doc["deviation"]["rms_mm"], **{k: v["rms_mm"] for k, v in doc["envelope"].items()}}
    html = report_html(check=chk)
    # the titles of the map and the 3D view: "the inflated <face> against Ŝ ...: RMS x mm"
    figs = plotly_figures(html)
    for div in ("check-map", "check-overlay"):
        title = figs[div][1]["title"]["text"]
        got = re.fullmatch(r"the inflated (\w+) face against Ŝ[^:]*: RMS (\d+\.\d) mm.*", title, flags=re.S)
        assert got and got.group(1) == face and float(got.group(2)) == pytest.approx(rms[face], abs=0.051), title
        assert "mid-surface" not in title or face == "mid"
    # the verdict: "The inflated <face> face is x mm RMS from Ŝ"
    got = re.search(r"The inflated (\w+) face is (\d+\.\d) mm RMS", html)
    assert got.group(1) == face and float(got.group(2)) == pytest.approx(rms[face], abs=0.051)
    # each face's table: every surface by name, its own number
    rows = table(html, "check-faces")
    assert rows[1][0].startswith(SURFACE[face]) and "named" in rows[1][0]
    for row in rows[1:]:
        which = next(k for k, v in SURFACE.items() if row[0].startswith(v))
        assert float(row[1]) == pytest.approx(rms[which], abs=0.051)
    assert len(rows) == 1 + len(rms)
    # the runs' table: its RMS column names the face, each run's number is that face's
    rows = table(html, "check-runs")
    col = rows[0].index(f"RMS, {face} face (mm)")
    for row in rows[1:]:
        assert float(row[col]) == pytest.approx(runs[row[0]], abs=0.051)
    # the curvature plot measures on the same face
    assert f"on the {face} face" in figs["check-curvature"][1]["yaxis"]["title"]["text"]


def test_the_map_on_omega_comes_first_and_the_3d_view_does_not_overlay_two_surfaces(run_objects):
    from airmat.report.check import deviation_map_figure, overlay_figure

    _, result, checked = run_objects
    html = report_html(check=checked)
    assert html.index('"check-map"') < html.index('"check-overlay"') < html.index('"check-curvature"')
    fig = deviation_map_figure(checked)
    heat = fig["data"][0]
    assert heat["type"] == "heatmap"
    # the grid's values are the median run's per-vertex deviation of the named face (mm), at (u, v)
    uv, per = result.approx.uv * 1000, checked.runs["median"].deviation.per_vertex * 1000
    u, v, z = np.asarray(heat["x"]), np.asarray(heat["y"]), np.asarray(heat["z"])
    for j in (0, len(v) // 2, len(v) - 1):
        for i in (0, len(u) // 3, len(u) - 1):
            k = np.argmin(np.hypot(uv[:, 0] - u[i], uv[:, 1] - v[j]))
            assert z[j, i] == pytest.approx(per[k], abs=0.006)     # rounded to 0.01 mm
    # the strings: one trace per face, every dash on it, told apart by colour and dash
    lines = [t for t in fig["data"][1:] if t.get("name", "").startswith("strings on the")]
    sides = {s.side for s in result.pattern.strings}
    assert {t["name"].split()[3] for t in lines} == sides
    assert sum(t["x"].count(None) for t in lines) == len(result.pattern.strings)
    # 3D: one surface (the inflated face, opaque), Ŝ as lines
    data = overlay_figure(checked)["data"]
    assert [t["type"] for t in data] == ["mesh3d", "scatter3d"]
    assert data[0]["opacity"] == 1.0 and data[1]["mode"] == "lines"


def _verdict(html: str) -> str:
    card = html[html.index('id="verdict"'):]
    return unescape(re.sub(r"<[^>]+>", "", card[:card.index("</div>")]))


def test_the_verdict_of_an_unrefined_design_says_refine_it(run_objects):
    _, result, checked = run_objects
    html = report_html(check=checked)
    assert html.index('id="verdict"') < html.index("<h2>")            # the first thing on the page
    text = _verdict(html)
    dev = checked.runs["median"].deviation
    within = dev.rms_pct_diag <= 1.0
    assert f"Lands within 1 % of the diagonal: {'yes' if within else 'no'}" in text
    assert f"({dev.rms_pct_diag:.2f} % of Ŝ's diagonal" in text and "open-loop string lengths" in text
    assert "Constructible: yes" in text
    lo, hi = checked.runs["lo95"].deviation, checked.runs["hi95"].deviation
    assert f"{lo.rms * 1000:.1f} mm ({lo.rms_pct_diag:.2f} %) at lo95" in text
    assert f"{hi.rms * 1000:.1f} mm ({hi.rms_pct_diag:.2f} %) at hi95" in text
    assert "Next: airmat refine DESIGN_DIR --out DESIGN_DIR-refined" in text
    # the design alone: not inflated yet, refine it
    text = _verdict(report_html(design=result))
    assert "not known yet" in text and "Next: airmat refine" in text and "± " in text


def test_the_verdict_of_a_refined_design_asks_for_a_band_then_the_workshop(run_objects):
    from test_page import _with_monte_carlo

    _, result, checked = run_objects
    dev = lambda rms, pct: {"rms_mm": rms, "rms_pct_diag": pct, "max_mm": 3 * rms}  # noqa: E731
    block = {"converged": True, "iterations": 9, "seconds": 1.0, "resolution_mm": 60.0, "surface": checked.surface,
             "lengths_before": "open-loop", "deviation_before": dev(12.0, 1.2), "deviation_after": dev(6.1, 0.61),
             "dropped": [], "flagged": [], "message": "converged"}
    refined = dataclasses.replace(result, refine=block, source="out/vault1-refined")
    text = _verdict(report_html(design=refined))
    assert "Lands within 1 % of the diagonal: yes (refined: the inflated" in text and "6.1 mm RMS" in text
    assert "Next: airmat check out/vault1-refined --out DIR --resolution-mm 60" in text
    # its check, landing within 0.6 %: a band next
    med = checked.runs["median"]
    close = dataclasses.replace(med, deviation=dataclasses.replace(med.deviation, rms=0.006, rms_pct_diag=0.6))
    chk = dataclasses.replace(checked, design=refined, runs={**checked.runs, "median": close})
    text = _verdict(report_html(check=chk))
    assert "Lands within 1 % of the diagonal: yes" in text and "refined string lengths" in text
    assert "Next: airmat check out/vault1-refined --samples 64 --out DIR" in text
    # with the band: its tolerance, and the workshop files
    with_mc = _with_monte_carlo(chk)
    st = with_mc.monte_carlo.stats()
    html = report_html(check=with_mc)
    text = _verdict(html)
    assert f"95 % of the built shapes within {st['rms_p95'] * 1000:.1f} mm RMS" in text
    assert "Next: airmat export out/vault1-refined --paper A4" in text and "cutting_list.csv" in text
    assert 'class="verdict ok"' in html
    # not constructible: red, and back to the design
    rep = dataclasses.replace(result.approx.report, constructible=False, reasons=["σ max 1.2 > 1.1"])
    bad = dataclasses.replace(refined, approx=dataclasses.replace(result.approx, report=rep))
    html = report_html(check=dataclasses.replace(chk, design=bad))
    assert 'class="verdict bad"' in html and "Constructible: NO (σ max 1.2 &gt; 1.1)" in html


def test_the_calibration_stands_beside_its_truth(run_objects):
    from airmat.calib.model import kappa1

    cal, _, _ = run_objects
    truth = {"delta_mm": 18.0, "d_mm": 70.0, "sigma_per_m": 0.05}
    html = report_html(calibration=cal, truth=truth)
    rows = table(html, "calibration-parameters")
    assert rows[0][4:] == ["truth", "median − truth", "truth in the 95 % interval"]
    p = cal.posterior
    for row, ps, t, scale in zip(rows[1:], (p.delta, p.d, p.sigma), (18.0, 70.0, 0.05), (1000, 1000, 1)):
        assert float(row[4]) == t
        assert float(row[5]) == pytest.approx(ps.median * scale - t, abs=0.006)
        assert row[6] == ("yes" if ps.lo95 * scale <= t <= ps.hi95 * scale else "NO")
    [curve] = [t for t in plotly_figures(html)["calibration-curve"][0] if t["name"].startswith("truth")]
    c = cal.curve
    np.testing.assert_allclose(curve["y"], kappa1(c.l_over_L * c.L, c.L, 0.018, 0.070), atol=1e-4)
    plain = report_html(calibration=cal)
    assert "median − truth" not in plain and '"truth (' not in plain


def test_the_calibration_summary_compares_with_the_truth(run_objects):
    from airmat.calib.calibration_io import summary_text

    cal, _, _ = run_objects
    p = cal.posterior
    far = p.delta.hi95 * 1000 + 5
    text = summary_text(cal, truth={"delta_mm": far, "d_mm": p.d.median * 1000})
    delta, d, sigma = text.splitlines()[:3]
    assert f"truth {far:.2f} mm, median - truth {p.delta.median * 1000 - far:+.2f}, OUTSIDE" in delta
    assert "median - truth +0.00, inside the 95% interval" in d and "truth" not in sigma
    assert "truth" not in summary_text(cal)


def test_the_distance_to_s_stands_beside_the_deviation_from_s_hat(run_objects):
    """The runs' table and the verdict give inflate.json's ``to_target`` numbers; a check without S gives none."""
    _, _, checked = run_objects
    doc = check_dict(checked)
    tt = doc["to_target"]
    assert "rms_mm" in tt and "approx" in tt            # the design in memory keeps S
    html = report_html(check=checked)
    rows = table(html, "check-runs")
    col = rows[0].index("to S: RMS mm (% diag)")
    blocks = {"median": tt, **{k: v["to_target"] for k, v in doc["envelope"].items()}}
    assert sorted(row[0] for row in rows[1:]) == sorted(blocks)
    for row in rows[1:]:
        rms, pct = re.fullmatch(r"(\d+\.\d) \((\d+\.\d\d)\)", row[col]).groups()
        # the table shows 0.1 mm and 0.01 %; inflate.json keeps 0.001 mm and 0.0001 %
        assert float(rms) == pytest.approx(blocks[row[0]]["rms_mm"], abs=0.051)
        assert float(pct) == pytest.approx(blocks[row[0]]["rms_pct_diag"], abs=0.0051)
    text = _verdict(html)
    got = re.search(r"The inflated (\w+) face is (\d+\.\d) mm RMS from your target S \((\d+\.\d\d) % of the "
                    r"diagonal\); Ŝ itself is (\d+\.\d) mm from S \((\d+\.\d\d) %\)\.", text)
    assert got and got.group(1) == tt["surface"] == checked.surface
    assert float(got.group(2)) == pytest.approx(tt["rms_mm"], abs=0.051)
    assert float(got.group(3)) == pytest.approx(tt["rms_pct_diag"], abs=0.0051)
    assert float(got.group(4)) == pytest.approx(tt["approx"]["rms_mm"], abs=0.051)
    assert float(got.group(5)) == pytest.approx(tt["approx"]["rms_pct_diag"], abs=0.0051)
    # read from a folder without target.ply: no column, no fact
    without = dataclasses.replace(checked, approx_to_target=None,
                                  runs={k: dataclasses.replace(r, to_target=None) for k, r in checked.runs.items()})
    html = report_html(check=without)
    assert "to S: RMS mm (% diag)" not in table(html, "check-runs")[0] and "target S" not in _verdict(html)


def test_where_part_of_the_face_lies_beyond_s_its_distance_over_s_is_given_too(run_objects, tmp_path):
    """S cut to its half: the faces beyond its new rim are measured to that rim, so inflate.json, the text, the
    runs' table and the verdict also give the distance over S alone, with its share of the face."""
    import trimesh

    from airmat.check.compare import distance_to_target
    from airmat.check.report import summary_text
    from airmat.design.target import Target

    _, _, checked = run_objects
    s = checked.design.approx.target
    half = trimesh.Trimesh(s.vertices, s.faces, process=False)
    keep = half.triangles_center[:, 0] < np.median(half.triangles_center[:, 0])
    half = half.submesh([np.flatnonzero(keep)], append=True)
    cut = Target(half.vertices, half.faces, name="half")
    a = checked.design.approx
    diag = float(np.linalg.norm(np.ptp(a.xyz, axis=0)))
    runs = {k: dataclasses.replace(r, to_target=distance_to_target(r.deviation.aligned, cut, diagonal=diag))
            for k, r in checked.runs.items()}
    halved = dataclasses.replace(checked, runs=runs, approx_to_target=distance_to_target(a.xyz, cut, diagonal=diag))
    med = runs["median"].to_target
    assert 0.3 < med.over_share < 0.7 and med.over_rms < med.rms       # the far half is measured to the cut
    tt = check_dict(halved)["to_target"]
    over = tt["over_target"]
    assert over["share"] == pytest.approx(med.over_share, abs=1e-4)
    assert over["rms_mm"] == pytest.approx(1e3 * med.over_rms, abs=1e-3)
    assert over["rms_pct_diag"] == pytest.approx(100 * med.over_rms / diag, abs=1e-4)
    assert tt["approx"]["over_target"]["rms_mm"] < over["rms_mm"]
    text = summary_text(check_dict(halved), tmp_path)
    assert (f"over S ({100 * over['share']:.0f}% of the face; the rest lies beyond its rim): RMS "
            f"{over['rms_mm']:.1f} mm ({over['rms_pct_diag']:.2f}%)") in text
    html = report_html(check=halved)
    rows = table(html, "check-runs")
    col = rows[0].index("to S: RMS mm (% diag)")
    cell = {row[0]: row[col] for row in rows[1:]}["median"]
    assert cell.endswith(f"; over S ({100 * over['share']:.0f} %): {over['rms_mm']:.1f}")
    got = re.search(r"Over S, (\d+) % of the face \(the rest lies beyond S's rim, where S says nothing\), it is "
                    r"(\d+\.\d) mm RMS from S \((\d+\.\d\d) %\)\.", _verdict(html))
    assert got and int(got.group(1)) == round(100 * over["share"])
    assert float(got.group(2)) == pytest.approx(over["rms_mm"], abs=0.051)
