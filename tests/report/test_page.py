"""The page's content from the objects in memory: sections, banners, cutting list, size, no network."""

import dataclasses
import re

import numpy as np

from airmat.design.mattress import Mattress, triangulate_mattress
from airmat.report.page import REPORT_NAME, report_html, write_report

PLOTS = ("calibration-curve", "design-pattern", "design-surface", "check-map", "check-overlay", "check-curvature")


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
    # the 3D traces (Ŝ, the inflated face) and the map hold the decimated grid, not all 42k vertices
    n_x = [len(m.group(1).split(",")) for m in re.finditer(r'"type":"mesh3d","name":"[^"]*","x":\[([^\]]*)\]', html)]
    assert len(n_x) == 2 and max(n_x) <= 12_000
    [z] = re.findall(r'"type":"heatmap".*?"z":(\[\[.*?\]\])', html)
    assert z.count("[") - 1 <= 12_000 ** 0.5 + 2


class _Dev:
    def __init__(self, rms, per):
        self.rms, self.per_vertex = rms, per


def _with_monte_carlo(checked, *, n=40, seed=3):
    """The check with a Monte-Carlo result summarized from made-up per-vertex deviations (seeded)."""
    from airmat.check.monte_carlo import MonteCarloDraws, summarize

    rng = np.random.default_rng(seed)
    k, nv = len(checked.design.pattern.strings), len(checked.design.approx.xyz)
    kappa = rng.normal(0, 1, (n, k))
    rms = 0.01 + 0.002 * kappa[:, 5] + 0.0002 * rng.normal(size=n)          # string 5 drives the RMS
    per = rng.uniform(0, 0.02, (n, nv))
    dr = MonteCarloDraws(seed=seed, delta=np.zeros(n), d=np.zeros(n), sigma=np.ones(n), kappa=kappa,
                         kappa_median=np.zeros(k), length=kappa, rest=kappa, sigma_source="posterior")
    mc = summarize(dr, [_Dev(r, p) for r, p in zip(rms, per)], tolerance=0.011)
    return dataclasses.replace(checked, monte_carlo=mc)


def test_the_monte_carlo_band_and_its_statistics_are_on_the_page(run_objects):
    from airmat.report.mesh import display_grid

    _, result, checked = run_objects
    assert 'id="check-band"' not in report_html(check=checked)          # no Monte-Carlo, no band
    with_mc = _with_monte_carlo(checked)
    mc = with_mc.monte_carlo
    html = report_html(check=with_mc)
    assert html.count('Plotly.newPlot("check-band"') == 1
    # the figure's colour is the 95 % quantile (mm) at the displayed vertices
    from airmat.report.check import band_figure, monte_carlo_table

    trace = band_figure(with_mc)["data"][0]
    keep, _ = display_grid(result.approx.uv, result.approx.faces)
    np.testing.assert_allclose(trace["intensity"], mc.per_vertex_q[1][keep] * 1000, atol=0.01)
    assert len(trace["x"]) == len(keep)
    assert f"95 % quantile of the {checked.surface} face's deviation (mm)" in html
    # the statistics table: samples, seed, RMS median / p95 with standard errors, P(RMS <= T)
    st = mc.stats()
    stats = html[html.index('id="monte-carlo-stats"'):].split("</table>")[0]
    assert "<td>samples</td><td>40</td>" in stats and "<td>seed</td><td>3</td>" in stats
    assert f"{st['rms_median'] * 1000:.2f} ± {st['rms_median_se'] * 1000:.2f}" in stats
    assert f"{st['rms_p95'] * 1000:.2f} ± {st['rms_p95_se'] * 1000:.2f}" in stats
    within = f"{st['p_within']:.3f} ± {st['p_within_se']:.3f}"
    assert f"P(RMS of the {checked.surface} face ≤ 11 mm)</td><td>{within}" in stats
    # the ten most sensitive strings, string 5 first
    strings = html[html.index('id="monte-carlo-strings"'):].split("</table>")[0]
    assert strings.count("<tr>") == 1 + 10
    first = strings.split("<tbody>")[1]
    assert first.startswith(f"<tr><td>{result.pattern.strings[5].dash.id}</td>")
    assert monte_carlo_table(with_mc)[1] in html


def test_a_refined_design_says_what_the_refinement_did(run_objects):
    _, result, _ = run_objects
    dev = lambda rms, pct, mx: {"rms_mm": rms, "rms_pct_diag": pct, "max_mm": mx}  # noqa: E731
    block = {"converged": False, "iterations": 20, "seconds": 12.34, "resolution_mm": 20.0,
             "coarse_resolution_mm": 40.0, "defect_corrections": 0, "alpha": 1e-3, "surface": "top",
             "lengths_before": "open-loop", "deviation_before": dev(12.73, 1.25, 45.5),
             "deviation_after": dev(7.11, 0.70, 29.2), "dropped": ["k1-003-01"], "flagged": [],
             "message": "not converged after 20 iterations",
             "reparametrization": {"rounds": 1, "moved_rms_mm": 3.4, "moved_max_mm": 5.7, "off_surface_rms_mm": 0.06,
                                   "off_surface_max_mm": 0.4, "deviation_before": dev(13.1, 1.29, 46.0)}}
    html = report_html(design=dataclasses.replace(result, refine=block))
    section = html[html.index("String lengths refined through the inflation"):html.index("Ŝ in 3D")]
    cells = re.findall(r"<td>(.*?)</td>", section)
    assert cells[:8] == ["before (open-loop lengths)", "12.7", "1.25", "45.5", "after (these lengths)", "7.1", "0.70",
                         "29.2"]
    assert "20 Gauss–Newton iterations, 12.3 s" in section and "on the 40 mm mesh" in section
    assert "Dropped (a string reached its flat span: not needed): k1-003-01" in section
    assert "moved 3.4 mm RMS" in section and "against the moved Ŝ: 13.1 mm RMS" in section
    assert "The refinement did not converge: not converged after 20 iterations" in banners_before_first_section(html)
    # an open-loop design has no such section
    assert "refined through the inflation" not in report_html(design=result)


def test_a_refined_designs_check_says_where_its_runs_started(run_objects):
    # a refined design's runs are carried on from its open-loop equilibrium (airmat.check.inflation_check): the page says so
    _, _, chk = run_objects
    base = dataclasses.replace(chk.runs["median"].inflation, n_iter=87)
    html = report_html(check=dataclasses.replace(chk, open_loop=base))
    assert "its open-loop strings were inflated from the flat mattress first (87 Newton iterations)" in html
    assert "open-loop strings were inflated" not in report_html(check=chk)
