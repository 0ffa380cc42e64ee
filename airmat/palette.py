"""The colours of every airmat figure: one home for report.html's plotly views and every PNG.

A run's string lengths (median, lo95, hi95), a string's face (top, bottom), a dash's family
(k1, k2), the calibration curve and the colour scales mean the same thing in ``report.html``
(plotly), ``deviation.png``, ``curve.png`` and ``preview.png`` (matplotlib), so each is named
once here. Colours are hex strings, which both libraries take; :func:`rgba` makes the
translucent fills. The figure modules read these names when they draw (``palette.RUNS[key]``),
not at import, so a change here (or a test's monkeypatch) reaches every figure.

The discrete colours are Paul Tol's colour-blind safe "vibrant" scheme; the deviation and
band scales are perceptually uniform (viridis, magma); σ diverges about 1 (blue: shrunk,
red: stretched).

Examples
--------
>>> from airmat import palette
>>> palette.RUNS["median"], palette.RUN_MARKERS["lo95"].plotly
('#0077BB', 'triangle-down')
>>> palette.rgba(palette.CALIBRATION["band"], 0.35)
'rgba(0,119,187,0.35)'
>>> palette.DEVIATION.plotly, palette.DEVIATION.matplotlib
('Viridis', 'viridis')
>>> palette.SIGMA.plotly[5], palette.SIGMA.matplotlib     # white at the middle: σ = 1
((0.5, '#F7F6F6'), 'RdBu_r')
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Scale", "Marker", "RUNS", "RUN_MARKERS", "FACES", "FACE_DASH", "HALO", "FAMILIES", "CALIBRATION",
           "DEVIATION", "BAND", "SIGMA", "rgba"]


@dataclass(frozen=True)
class Scale:
    """A continuous colour scale in each library (the same colours, low to high).

    Attributes
    ----------
    plotly : str or tuple of (float, str)
        A colour scale plotly.js knows by name, or its stops ``(position in [0, 1], "#RRGGBB")``.
    matplotlib : str
        A matplotlib colour map name.
    """

    plotly: object
    matplotlib: str


@dataclass(frozen=True)
class Marker:
    """A marker by its name in each library (the same shape)."""

    plotly: str
    matplotlib: str


#: the three inflations of a check, by the string lengths they use
RUNS = {"median": "#0077BB", "lo95": "#EE7733", "hi95": "#009988"}
#: their markers: the shortest strings point down, the longest up
RUN_MARKERS = {"median": Marker("circle", "o"), "lo95": Marker("triangle-down", "v"),
               "hi95": Marker("triangle-up", "^")}
#: a string's face, where strings of both faces share a view (the deviation map)
FACES = {"top": "#EE3377", "bottom": "#000000"}
#: and its line style: (plotly dash, matplotlib linestyle)
FACE_DASH = {"top": ("solid", "-"), "bottom": ("dash", (0, (4, 2)))}
#: drawn under a string on a coloured map so that it reads on every colour of the scale
HALO = "#FFFFFF"
#: a dash's family: κ₁ (across the bending) and κ₂
FAMILIES = {"k1": "#CC3311", "k2": "#0077BB"}
#: the calibration curve: posterior median and its bands, the specimens, the true curve of a synthetic set
CALIBRATION = {"median": "#0077BB", "band": "#0077BB", "specimens": "#CC3311", "truth": "#000000"}

#: deviation of an inflated face from Ŝ (mm), 0 upward
DEVIATION = Scale("Viridis", "viridis")


def _stops(colours) -> tuple:
    """Evenly spaced plotly stops ``((0, c0), ..., (1, cn))``."""
    return tuple((round(i / (len(colours) - 1), 4), c) for i, c in enumerate(colours))


#: the Monte-Carlo band: a vertex's 95 % quantile of the deviation (mm); plotly.js has no magma by name,
#: so the page gets matplotlib's magma at ninths as stops
BAND = Scale(_stops(("#000004", "#180F3D", "#440F76", "#721F81", "#9E2F7F", "#CD4071", "#F1605D", "#FD9668",
                     "#FECA8D", "#FCFDBF")), "magma")
#: σ, edge length on Ŝ over Ω, centred on 1: blue below, red above (matplotlib's RdBu_r at tenths: plotly.js's
#: RdBu has other colours)
SIGMA = Scale(_stops(("#053061", "#2065AB", "#4393C3", "#90C4DD", "#D1E5F0", "#F7F6F6", "#FDDBC7", "#F3A481",
                      "#D6604D", "#B1182B", "#67001F")), "RdBu_r")


def rgba(colour: str, alpha: float) -> str:
    """``"rgba(r,g,b,alpha)"`` of a ``"#RRGGBB"`` colour (a translucent plotly fill).

    Examples
    --------
    >>> rgba("#FF8000", 0.5)
    'rgba(255,128,0,0.5)'
    """
    if len(colour) != 7 or colour[0] != "#":
        raise ValueError(f"expected a colour '#RRGGBB', got {colour!r}")
    r, g, b = (int(colour[i:i + 2], 16) for i in (1, 3, 5))
    return f"rgba({r},{g},{b},{alpha:g})"
