"""Calibration figures: the kappa_1(l / L) curve with bands, and the corner plot.

:func:`curve_figure` and :func:`corner_figure` return a
``matplotlib.figure.Figure`` (a notebook shows it); :func:`plot_curve` and
:func:`plot_corner` write them as PNG files. No pyplot state
(:mod:`airmat.figures`), so they work headless and in threads.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from airmat import palette
from airmat.figures import new_figure, save_png

__all__ = ["curve_figure", "corner_figure", "plot_curve", "plot_corner"]


def curve_figure(cal, *, truth: dict | None = None):
    """The calibration curve: measured kappa (with 2-sigma error bars) against l / L, and the fit.

    Like the paper's Figure 3: posterior median of kappa_1 and its 68% / 95%
    bands for the most common L; measured curvatures of the specimens with
    that L as points with error bars ``2 sqrt(s_i^2 + sigma^2)``.

    Parameters
    ----------
    cal : airmat.calib.calibrate.Calibration
    truth : dict, optional
        ``{"delta_mm", "d_mm"}``: the true curve is drawn dashed.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from airmat.calib.model import kappa1

    c, p, colour = cal.curve, cal.posterior, palette.CALIBRATION
    fig = new_figure((6.4, 4.4), layout="constrained")
    ax = fig.add_subplot()
    ax.fill_between(c.l_over_L, c.lo95, c.hi95, color=colour["band"], alpha=0.18, lw=0, label="95% band")
    ax.fill_between(c.l_over_L, c.lo68, c.hi68, color=colour["band"], alpha=0.35, lw=0, label="68% band")
    ax.plot(c.l_over_L, c.median, color=colour["median"], lw=1.8,
            label=f"posterior median (Δ={p.delta.median * 1e3:.1f} mm, d={p.d.median * 1e3:.1f} mm)")
    if truth is not None:
        k = kappa1(c.l_over_L * c.L, c.L, truth["delta_mm"] * 1e-3, truth["d_mm"] * 1e-3)
        ax.plot(c.l_over_L, k, "--", color=colour["truth"], lw=1.0,
                label=f"truth (Δ={truth['delta_mm']:g} mm, d={truth['d_mm']:g} mm)")
    same_L = np.array([np.isclose(s.L, c.L) for s in cal.specimens])
    x = np.array([s.l / s.L for s in cal.specimens])
    y = np.array([s.kappa for s in cal.specimens])
    err = 2.0 * np.hypot([s.kappa_se for s in cal.specimens], p.sigma.median)
    ax.errorbar(x[same_L], y[same_L], yerr=err[same_L], fmt="o", color=colour["specimens"], ms=4, capsize=2,
                label="measured (±2 sd incl. scatter σ)")
    ax.set_xlabel("string length ratio l / L  (L = %g mm)" % (c.L * 1e3))
    ax.set_ylabel("curvature κ₁  (1/m)")
    ax.set_xlim(0.0, 1.0)
    ax.set_ylim(bottom=min(0.0, float(np.min(y - err))))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def plot_curve(cal, path, *, truth: dict | None = None) -> Path:
    """Write curve.png, the :func:`curve_figure` (120 dpi); return its path."""
    return save_png(curve_figure(cal, truth=truth), path, dpi=120)


def corner_figure(posterior, *, truths: dict | None = None):
    """The corner plot: 1D and 2D marginals of Delta (mm), d (mm) and sigma (1/m).

    Parameters
    ----------
    posterior : airmat.calib.posterior.Posterior
    truths : dict, optional
        ``{"delta_mm", "d_mm", "sigma_per_m"}`` (any subset): marked on the plot.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import corner

    s = posterior.samples * np.array([1e3, 1e3, 1.0])
    keys = ("delta_mm", "d_mm", "sigma_per_m")
    marks = None if truths is None else [truths.get(k) for k in keys]
    fig = new_figure((6.0, 6.0), layout="constrained")
    fig.set_layout_engine(None)
    corner.corner(s, fig=fig, labels=["Δ (mm)", "d (mm)", "σ (1/m)"], truths=marks,
                  quantiles=[0.025, 0.5, 0.975], show_titles=True, title_fmt=".3g",
                  title_kwargs={"fontsize": 9}, label_kwargs={"fontsize": 10})
    return fig


def plot_corner(posterior, path, *, truths: dict | None = None) -> Path:
    """Write corner.png, the :func:`corner_figure` (110 dpi); return its path."""
    return save_png(corner_figure(posterior, truths=truths), path, dpi=110)
