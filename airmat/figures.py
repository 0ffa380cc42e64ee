"""Figures without pyplot: build a ``matplotlib.figure.Figure``, return it, save it atomically.

Every plot function of airmat builds its figure with :func:`new_figure` and
returns it, so a notebook can show it; the writers save it with
:func:`save_png`. No ``matplotlib.use`` and no pyplot global state: figures
work headless, in threads and next to a user's own pyplot session, and
matplotlib is imported only when a figure is made.
"""

from __future__ import annotations

import io
from pathlib import Path

from airmat.atomic import atomic_write_bytes

__all__ = ["new_figure", "save_png"]


def new_figure(figsize: tuple[float, float], **kwargs):
    """A ``matplotlib.figure.Figure`` on an Agg canvas, outside pyplot.

    Parameters
    ----------
    figsize : (float, float)
        Width and height in inches.
    **kwargs
        Passed to ``Figure`` (e.g. ``layout="constrained"``).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, **kwargs)
    FigureCanvasAgg(fig)
    return fig


def save_png(fig, path, *, dpi: float) -> Path:
    """Write ``fig`` as a PNG file through :func:`airmat.atomic.atomic_write_bytes`; return the path.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    path : path
        File to write (replaced atomically: a failure leaves no partial file).
    dpi : float
        Resolution in dots per inch.
    """
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    path = Path(path)
    atomic_write_bytes(path, buf.getvalue())
    return path
