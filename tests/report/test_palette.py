"""One palette (airmat.palette) for report.html and every PNG: the colours on the page are the palette's, and a
change of the palette reaches the HTML and the PNG writers (deviation.png, curve.png, preview.png)."""

import numpy as np
import pytest
from matplotlib.colors import to_hex

from airmat import palette
from airmat.report.page import report_html
from test_truth import plotly_figures


def _by_name(data, prefix):
    return [t for t in data if t.get("name", "").startswith(prefix)]


def test_the_pages_colours_are_the_palettes(run_objects):
    cal, result, checked = run_objects
    figs = plotly_figures(report_html(calibration=cal, design=result, check=checked,
                                      truth={"delta_mm": 18, "d_mm": 70}))
    data = figs["check-curvature"][0]
    for key in checked.runs:
        [t] = _by_name(data, f"strings at {key}")
        assert t["marker"]["color"] == palette.RUNS[key] and t["marker"]["symbol"] == palette.RUN_MARKERS[key].plotly
    for side in {s.side for s in result.pattern.strings}:
        [t] = _by_name(figs["check-map"][0], f"strings on the {side} face")
        assert t["line"]["color"] == palette.FACES[side] and t["line"]["dash"] == palette.FACE_DASH[side][0]
    assert figs["check-map"][0][0]["colorscale"] == palette.DEVIATION.plotly
    assert figs["check-overlay"][0][0]["colorscale"] == palette.DEVIATION.plotly
    for t in _by_name(figs["design-pattern"][0], "bottom k") + _by_name(figs["design-pattern"][0], "top k"):
        assert t["line"]["color"] == palette.FAMILIES[t["name"].split()[1]]
    assert figs["design-surface"][0][0]["colorscale"] == [list(s) for s in palette.SIGMA.plotly]
    cal_data = figs["calibration-curve"][0]
    assert _by_name(cal_data, "posterior median")[0]["line"]["color"] == palette.CALIBRATION["median"]
    assert _by_name(cal_data, "specimens")[0]["marker"]["color"] == palette.CALIBRATION["specimens"]
    assert _by_name(cal_data, "truth")[0]["line"]["color"] == palette.CALIBRATION["truth"]
    assert _by_name(cal_data, "95 % band")[0]["fillcolor"] == palette.rgba(palette.CALIBRATION["band"], 0.18)


def test_deviation_png_and_the_page_agree_on_the_runs_colours(run_objects):
    from airmat.check.report import deviation_figure

    _, _, checked = run_objects
    ax = deviation_figure(checked).axes[2]        # the map, its colour bar, the curvature panel
    for line in ax.get_lines()[1:]:               # after the line y = x
        key = line.get_label().split()[-1]
        assert to_hex(line.get_color()).upper() == palette.RUNS[key]
        assert line.get_marker() == palette.RUN_MARKERS[key].matplotlib


@pytest.fixture
def repainted(monkeypatch):
    """A palette with every colour changed: what each figure draws must follow it."""
    monkeypatch.setitem(palette.RUNS, "lo95", "#123456")
    monkeypatch.setitem(palette.FACES, "bottom", "#654321")
    monkeypatch.setitem(palette.FAMILIES, "k1", "#0A0B0C")
    monkeypatch.setitem(palette.CALIBRATION, "specimens", "#ABCDEF")
    monkeypatch.setitem(palette.CALIBRATION, "truth", "#FEDCBA")
    monkeypatch.setattr(palette, "DEVIATION", palette.Scale("Cividis", "cividis"))
    monkeypatch.setattr(palette, "SIGMA", palette.Scale("PiYG", "PiYG"))
    return palette


def test_a_change_of_the_palette_reaches_the_page(run_objects, repainted):
    cal, result, checked = run_objects
    html = report_html(calibration=cal, design=result, check=checked, truth={"delta_mm": 18, "d_mm": 70})
    for colour in ("#123456", "#654321", "#0A0B0C", "#ABCDEF", "#FEDCBA"):
        assert f'"color":"{colour}"' in html, colour
    assert '"colorscale":"Cividis"' in html and '"colorscale":"PiYG"' in html


def test_a_change_of_the_palette_reaches_every_png(run_objects, repainted):
    from airmat.calib.plots import curve_figure
    from airmat.check.report import deviation_figure
    from airmat.design.design_io import document
    from airmat.design.export.preview import preview_figure

    cal, result, checked = run_objects
    fig = deviation_figure(checked)
    colours = {to_hex(c).upper() for ax in fig.axes for line in ax.get_lines() for c in [line.get_color()]}
    assert {"#123456", "#654321"} <= colours                       # the lo95 run, the bottom face's strings
    assert fig.axes[0].collections[0].get_cmap().name == "cividis"    # the deviation map
    curve = curve_figure(cal, truth={"delta_mm": 18, "d_mm": 70}).axes[0]
    assert {"#FEDCBA", "#ABCDEF"} <= {to_hex(line.get_color()).upper() for line in curve.get_lines()}
    a = result.approx
    pre = preview_figure(document(result), a.xyz, a.uv, a.faces)
    # σ's colour bar (its solids carry the colour map) and the surface coloured through it
    assert "PiYG" in {c.get_cmap().name for ax in pre.axes for c in ax.collections if hasattr(c, "get_cmap")}


#: the colour scales plotly.js knows by name (src/components/colorscale/scales.js); any other name falls back silently
PLOTLY_JS_SCALES = {"Greys", "YlGnBu", "Greens", "YlOrRd", "Bluered", "RdBu", "Reds", "Blues", "Picnic", "Rainbow",
                    "Portland", "Jet", "Hot", "Blackbody", "Earth", "Electric", "Viridis", "Cividis"}


@pytest.mark.parametrize("name", ["DEVIATION", "BAND", "SIGMA"])
def test_each_scale_is_one_scale_in_both_libraries(name):
    from matplotlib import colormaps

    scale = getattr(palette, name)
    cmap = colormaps[scale.matplotlib]
    if isinstance(scale.plotly, str):
        assert scale.plotly in PLOTLY_JS_SCALES
        ends = {"Viridis": ("#440154", "#FDE725")}[scale.plotly]
        # plotly.js's Viridis is matplotlib's: the same ends (0-255 per channel, rounding)
        for at, colour in zip((0.0, 1.0), ends):
            got = np.array(cmap(at)[:3]) * 255
            want = np.array([int(colour[i:i + 2], 16) for i in (1, 3, 5)])
            assert np.abs(got - want).max() <= 1, (name, at)
    else:
        for at, colour in scale.plotly:
            assert to_hex(cmap(at)).upper() == colour
