"""The report in a real browser (headless Chromium): it draws its plots and 3D views offline, without errors."""

import numpy as np
import pytest

from airmat.report.page import write_report
from report_browser import open_page


def _not_blank(png) -> float:
    """Share of the screenshot's pixels that are not background white."""
    from matplotlib.image import imread

    img = imread(png)[..., :3]
    assert img.std() > 0.05
    return float(np.mean(img.min(axis=2) < 0.9))  # text, lines, surfaces


def test_the_browser_checks_catch_requests_and_errors(tmp_path):
    page = tmp_path / "reaching_out.html"
    page.write_text('<html><body><img src="http://airmat-probe.invalid/x.png">'
                    '<script>fetch("https://airmat-probe.invalid/f"); undefinedFunction();</script></body></html>')
    seen = open_page(page, tmp_path / "browser", probe_gl=False, height=400, budget_ms=3000)
    assert "http://airmat-probe.invalid/x.png" in seen.requests
    assert "https://airmat-probe.invalid/f" in seen.requests
    assert any("undefinedFunction" in e for e in seen.console_errors)


def test_demo_report_renders_offline(run_objects, tmp_path_factory):
    cal, result, checked = run_objects
    out = tmp_path_factory.mktemp("demo_report")
    page = write_report(out, calibration=cal, design=result, check=checked, summary="demo summary",
                        title="airmat demo: vault1")
    seen = open_page(page, out / "browser")
    print(f"screenshot of the demo report: {seen.screenshot}; WebGL pixels drawn: {seen.gl_pixels}")
    assert seen.console_errors == [] and seen.requests == []
    # five plotly graphs drawn (each adds its main-svg); two 3D scenes, each a WebGL canvas with a mesh on it
    assert seen.dom.count('class="main-svg"') >= 5
    assert seen.dom.count("<canvas") >= 2 and len(seen.gl_pixels) == 2
    for drawn, total in seen.gl_pixels:
        assert drawn > 0.05 * total, seen.gl_pixels
    assert seen.dom.count('class="trace scatter') >= 4  # the curve's bands, median and specimens, dashes
    assert _not_blank(seen.screenshot) > 0.05


@pytest.mark.slow
@pytest.mark.parametrize("part", ["calibration", "design", "check"])
def test_each_command_report_renders_offline(run_objects, tmp_path, part):
    cal, result, checked = run_objects
    kwargs = {"calibration": {"calibration": cal}, "design": {"design": result}, "check": {"check": checked}}[part]
    seen = open_page(write_report(tmp_path, **kwargs), tmp_path / "browser", height=3000)
    assert seen.console_errors == [] and seen.requests == []
    assert seen.dom.count('class="main-svg"') >= 1
    assert len(seen.gl_pixels) == {"calibration": 0, "design": 1, "check": 1}[part]
    assert all(drawn > 0.05 * total for drawn, total in seen.gl_pixels), seen.gl_pixels
    assert _not_blank(seen.screenshot) > 0.01
