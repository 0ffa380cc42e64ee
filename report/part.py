"""One part of ``report.html``, and the HTML of a plotly figure on it: what each part module builds.

:mod:`airmat.report.calibration`, :mod:`airmat.report.design` and :mod:`airmat.report.check` each
return a :class:`Part`; :func:`airmat.report.page.report_html` puts the parts on one page.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from html import escape

import numpy as np

__all__ = ["Part", "figure_html"]


@dataclass(frozen=True)
class Part:
    """One part of the page: a heading, its HTML body, and the banners for the top of the page.

    Attributes
    ----------
    title : str
    body : str
        HTML (figures as :func:`figure_html`).
    banners : tuple of (str, str)
        ``(kind, text)`` with kind ``"warn"``, ``"bad"`` or ``"ok"``: shown at the top.
    """

    title: str
    body: str
    banners: tuple = ()


def _jsonable(obj):
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.floating, np.integer, np.bool_)):
        return obj.item()
    raise TypeError(f"not JSON serializable: {type(obj).__name__}")


def figure_html(fig: dict, div_id: str, *, height: int = 480) -> str:
    """A ``<div>`` and the script that draws plotly figure ``fig`` into it.

    Parameters
    ----------
    fig : dict
        ``{"data": [trace dicts], "layout": {...}}``; numpy arrays are written as lists
        (round them first: every digit is a byte of the page).
    div_id : str
        Unique id of the div on the page.
    height : int
        Height in pixels.

    Returns
    -------
    str
    """
    layout = {"height": height, "margin": {"l": 60, "r": 20, "t": 40, "b": 50}, **fig.get("layout", {})}
    data = json.dumps(fig["data"], default=_jsonable, separators=(",", ":"), allow_nan=False,
                      ensure_ascii=False)
    lay = json.dumps(layout, default=_jsonable, separators=(",", ":"), allow_nan=False,
                      ensure_ascii=False)
    config = '{"responsive":true,"displaylogo":false,"showLink":false,"showSendToCloud":false}'
    # "</" would end the script element early
    data, lay = data.replace("</", "<\\/"), lay.replace("</", "<\\/")
    return (f'<div id="{escape(div_id)}" class="plot"></div>\n'
            f'<script>Plotly.newPlot("{escape(div_id)}",{data},{lay},{config});</script>\n')
