"""The page's content from the objects in memory: sections, banners, cutting list, size, no network."""

import dataclasses
import re

import numpy as np

from design.mattress import Mattress, triangulate_mattress
from report.page import REPORT_NAME, report_html, write_report

PLOTS = ("calibration-curve", "design-pattern", "design-surface", "check-overlay", "check-curvature")


def network_references(html: str) -> list:
    """src= / href= / url() pointing at http(s) in the markup and styles (the inlined scripts excluded)."""
    markup = re.sub(r"<script>.*?</script>", "", html, flags=re.S)
    return re.findall(r"""(?:src|href)\s*=\s*["']?\s*(?:https?:)?//|url\(\s*["']?(?:https?:)?//""", markup)


def banners_before_first_section(html: str) -> str:
    return html[html.index("<body>"):html.index("<h2>")]


def test_full_report_has_every_part(run_objects, tmp_path):
    cal, result, checked = run_objects
    path = write_report(tmp_path, calibration=cal, design=result, check=checked, summary="the summary")
    assert path == tmp_path / REPORT_NAME
    html = path.read_text(encoding="utf-8")
    for div in PLOTS:
        assert html.count(f'Plotly.newPlot("{div}"') == 1, div
    assert html.count("plotly.js v") == 1 and "the summary" in html
    assert network_references(html) == []
    # one cutting-list row per string, with its id
    table = html[html.index('id="cutting-list"'):]
    table = table[:table.index("</table>")]
    assert table.count("<tr>") == len(result.pattern.strings) + 1
    assert all(s.dash.id in table for s in result.pattern.strings)
    assert "UNCALIBRATED" not in html and "NOT" not in banners_before_first_section(html)
    assert len(cal.specimens) == html[html.index('id="specimens"'):].split("</table>")[0].count("<tr>") - 1


def test_the_network_check_finds_a_remote_script():
    assert network_references('<script src="https://cdn.plot.ly/x.js"></script><img src=//a.b/c>') != []
    assert network_references("<script>var u = 'https://x';</script>") == []


def test_uncalibrated_design_says_so_at_the_top(uncalibrated_design, run_objects):
    _, _, checked = run_objects
    html = report_html(design=uncalibrated_design)
    assert "UNCALIBRATED design" in banners_before_first_section(html)
    # an inflate report (the check alone) says it too
    html = report_html(check=dataclasses.replace(checked, design=uncalibrated_design))
    assert "UNCALIBRATED design" in banners_before_first_section(html)


def test_no_strings_and_no_convergence_are_on_the_page(run_objects):
    _, result, checked = run_objects
    bare = dataclasses.replace(result, pattern=dataclasses.replace(result.pattern, strings=()))
    html = report_html(design=bare)
    assert "The design has no strings" in banners_before_first_section(html)
    assert 'id="cutting-list"' not in html
    med = checked.runs["median"]
    failed = dataclasses.replace(med, inflation=dataclasses.replace(med.inflation, converged=False,
                                                                    message="stalled at stage 2"))
    html = report_html(check=dataclasses.replace(checked, runs={**checked.runs, "median": failed}))
    top = banners_before_first_section(html)
    assert "Inflation did NOT converge for median" in top and "stalled at stage 2" in html


def test_a_large_mattress_stays_under_10_mb(run_objects):
    """A 2600 x 1600 mm mattress at 10 mm (42k vertices, 4x the roof preset's): decimated for display."""
    _, result, checked = run_objects
    mattress = Mattress(2.6, 1.6, 0.07)
    uv, faces = triangulate_mattress(mattress, spacing=0.01)
    xyz = np.column_stack([uv, 0.3 * np.sin(np.pi * uv[:, 0] / 2.6)])
    approx = dataclasses.replace(result.approx, mattress=mattress, uv=uv, xyz=xyz, faces=faces)
    big = dataclasses.replace(result, approx=approx)
    med = checked.runs["median"]
    dev = dataclasses.replace(med.deviation, per_vertex=np.full(len(uv), 1e-3), aligned=xyz + [0, 0, 1e-3])
    big_check = dataclasses.replace(checked, design=big,
                                    runs={k: dataclasses.replace(r, deviation=dev) for k, r in checked.runs.items()})
    html = report_html(design=big, check=big_check)
    assert len(html.encode("utf-8")) < 10e6
    # the 3D traces hold the decimated grid, not all 42k vertices
    n_x = [len(m.group(1).split(",")) for m in re.finditer(r'"type":"mesh3d","name":"[^"]*","x":\[([^\]]*)\]', html)]
    assert len(n_x) == 3 and max(n_x) <= 12_000
