"""One self-contained ``report.html``: the parts of a run on one page, plotly.js inlined once.

:func:`report_html` assembles the page from the objects a run holds (a
``Calibration``, a ``DesignResult``, a ``DesignCheck``; any subset) and
:func:`write_report` writes it atomically. Figures are plotly figure
dictionaries (``{"data": [...], "layout": {...}}``) built by the part modules
(:mod:`airmat.report.calibration`, :mod:`airmat.report.design`, :mod:`airmat.report.check`; each a
:class:`~airmat.report.part.Part`, re-exported here) and drawn by the inlined plotly.js: the page
makes no request to any server.
Numbers on the page are in millimetres and 1/m.
"""

from __future__ import annotations

from html import escape
from pathlib import Path

from airmat.atomic import atomic_write_text
from airmat.report.part import Part, figure_html
from airmat.report.table import SORT_JS

__all__ = ["Part", "figure_html", "plotly_js", "report_html", "write_report", "REPORT_NAME"]

REPORT_NAME = "report.html"

_CSS = """
body { font-family: system-ui, sans-serif; margin: 1.5em auto; max-width: 1250px; color: #222; }
h1 { font-size: 1.5em; } h2 { border-bottom: 2px solid #ccc; margin-top: 2em; } h3 { margin-top: 1.4em; }
.banner { padding: .7em 1em; margin: .8em 0; font-weight: bold; border-radius: 4px; }
.banner.warn { background: #fff3cd; border: 1px solid #e0b000; }
.banner.bad { background: #fde2e1; border: 1px solid #c0392b; color: #8b1a10; }
.banner.ok { background: #e3f5e1; border: 1px solid #2e8b57; }
.verdict { padding: .6em 1.2em; margin: 1em 0; border-radius: 6px; border: 2px solid; }
.verdict.ok { background: #e3f5e1; border-color: #2e8b57; }
.verdict.warn { background: #fff3cd; border-color: #e0b000; }
.verdict.bad { background: #fde2e1; border-color: #c0392b; }
.verdict .headline { font-size: 1.15em; font-weight: bold; } .verdict ul { margin: .3em 0; }
.verdict code { background: #fff; padding: .1em .4em; border: 1px solid #ccc; border-radius: 3px; }
table { border-collapse: collapse; margin: .5em 0; font-size: .9em; }
th, td { border: 1px solid #ccc; padding: .2em .6em; text-align: right; }
th { background: #f2f2f2; } td:first-child, th:first-child { text-align: left; }
table.sortable th { cursor: pointer; } table.sortable th[data-sort=asc]::after { content: " \\25B2"; }
table.sortable th[data-sort=desc]::after { content: " \\25BC"; }
.scroll { max-height: 32em; overflow-y: auto; display: inline-block; }
.plot { width: 100%; } pre { background: #f7f7f7; padding: .8em; overflow-x: auto; }
"""


def plotly_js() -> str:
    """The minified plotly.js that ships with the plotly package (inlined: no CDN)."""
    from importlib.resources import files

    return (files("plotly") / "package_data" / "plotly.min.js").read_text(encoding="utf-8")


def report_html(*, calibration=None, design=None, check=None, summary: str | None = None,
                title: str = "airmat report", truth: dict | None = None, asbuilt=None) -> str:
    """The whole page for the objects given (any subset; the check brings its design if none is given).

    A verdict card opens the page (:mod:`airmat.report.verdict`): the check's when there is one,
    else the design's, else the calibration's.

    Parameters
    ----------
    calibration : airmat.calib.calibrate.Calibration, optional
    design : airmat.design.pipeline.DesignResult, optional
    check : airmat.check.inflation_check.DesignCheck, optional
    summary : str, optional
        Plain text shown first (the demo's summary).
    title : str
    truth : dict, optional
        The truth of a synthetic calibration set (``delta_mm``, ``d_mm``, optionally ``sigma_per_m``),
        shown beside the calibration's posterior.
    asbuilt : airmat.asbuilt.pipeline.AsBuilt, optional
        A scan of the built mattress and its correction (``airmat correct``): its part comes first.

    Returns
    -------
    str
        HTML5 with every script and all data inlined.
    """
    if calibration is None and design is None and check is None:
        raise ValueError("a report needs a calibration, a design or a check")
    parts = []
    if asbuilt is not None:
        from airmat.report.asbuilt import asbuilt_part
        parts.append(asbuilt_part(asbuilt))
    # each part imports its own stage's packages: a calibration report loads no design code
    if calibration is not None:
        from airmat.report.calibration import calibration_part
        parts.append(calibration_part(calibration, truth=truth))
    if design is not None:
        from airmat.report.design import design_part
        parts.append(design_part(design))
    if check is not None:
        from airmat.report.check import check_part
        parts.append(check_part(check, with_design_banner=design is None))
    from airmat.report.verdict import calibration_verdict, check_verdict, design_verdict, verdict_html

    card = (check_verdict(check) if check is not None else design_verdict(design) if design is not None
            else calibration_verdict(calibration))
    banners = [b for p in parts for b in p.banners]
    see = (("check-map", f"Where the inflated {check.surface} face misses Ŝ: the map on the mattress"),) \
        if check is not None else ()
    head = verdict_html(card, see=see) + "".join(f'<div class="banner {k}">{escape(t)}</div>\n'
                                                 for k, t in dict.fromkeys(banners))
    if summary:
        head += f"<h2>Summary</h2>\n<pre>{escape(summary)}</pre>\n"
    body = "".join(f"<h2>{escape(p.title)}</h2>\n{p.body}\n" for p in parts)
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n"
            f"<title>{escape(title)}</title>\n<style>{_CSS}</style>\n"
            f"<script>{plotly_js()}</script>\n</head>\n<body>\n<h1>{escape(title)}</h1>\n{head}{body}"
            f"<script>{SORT_JS}</script>\n</body></html>\n")


def write_report(folder, **kwargs) -> Path:
    """Write ``folder/report.html`` atomically (arguments as :func:`report_html`); return its path."""
    path = Path(folder) / REPORT_NAME
    atomic_write_text(path, report_html(**kwargs))
    return path
