"""Calibration figures: the kappa_1(l / L) curve with bands, and the corner plot.

Figures are drawn on ``matplotlib.figure.Figure`` objects with the Agg
canvas, never through pyplot's global state, so they work headless and
in threads.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["plot_curve", "plot_corner"]


def _figure(figsize):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def plot_curve(cal, path, *, truth: dict | None = None) -> Path:
    """curve.png: measured kappa (with 2-sigma error bars) against l / L, and the calibrated curve.

    Like the paper's Figure 3: posterior median of kappa_1 and its 68% / 95%
    bands for the most common L; measured curvatures of the specimens with
    that L as points with error bars ``2 sqrt(s_i^2 + sigma^2)``.

    Parameters
    ----------
    cal : calib.calibrate.Calibration
    path : path
        PNG file to write.
    truth : dict, optional
        ``{"delta_mm", "d_mm"}``: the true curve is drawn dashed.
    """
    from calib.model import kappa1

    c, p = cal.curve, cal.posterior
    fig = _figure((6.4, 4.4))
    ax = fig.add_subplot()
    ax.fill_between(c.l_over_L, c.lo95, c.hi95, color="C0", alpha=0.18, lw=0, label="95% band")
    ax.fill_between(c.l_over_L, c.lo68, c.hi68, color="C0", alpha=0.35, lw=0, label="68% band")
    ax.plot(c.l_over_L, c.median, color="C0", lw=1.8,
            label=f"posterior median (Δ={p.delta.median * 1e3:.1f} mm, d={p.d.median * 1e3:.1f} mm)")
    if truth is not None:
        k = kappa1(c.l_over_L * c.L, c.L, truth["delta_mm"] * 1e-3, truth["d_mm"] * 1e-3)
        ax.plot(c.l_over_L, k, "k--", lw=1.0,
                label=f"truth (Δ={truth['delta_mm']:g} mm, d={truth['d_mm']:g} mm)")
    same_L = np.array([np.isclose(s.L, c.L) for s in cal.specimens])
    x = np.array([s.l / s.L for s in cal.specimens])
    y = np.array([s.kappa for s in cal.specimens])
    err = 2.0 * np.hypot([s.kappa_se for s in cal.specimens], p.sigma.median)
    ax.errorbar(x[same_L], y[same_L], yerr=err[same_L], fmt="o", color="C3", ms=4, capsize=2,
                label="measured (±2 sd incl. scatter σ)")
    ax.set_xlabel("string length ratio l / L  (L = %g mm)" % (c.L * 1e3))
    ax.set_ylabel("curvature κ₁  (1/m)")
    ax.set_xlim(0.0, 1.0)
    ax.set_ylim(bottom=min(0.0, float(np.min(y - err))))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    path = Path(path)
    fig.savefig(path, dpi=120)
    return path


def plot_corner(posterior, path, *, truths: dict | None = None) -> Path:
    """corner.png: 1D and 2D marginals of Delta (mm), d (mm) and sigma (1/m).

    Parameters
    ----------
    posterior : calib.posterior.Posterior
    path : path
        PNG file to write.
    truths : dict, optional
        ``{"delta_mm", "d_mm", "sigma_per_m"}`` (any subset): marked on the plot.
    """
    import corner

    s = posterior.samples * np.array([1e3, 1e3, 1.0])
    keys = ("delta_mm", "d_mm", "sigma_per_m")
    marks = None if truths is None else [truths.get(k) for k in keys]
    fig = _figure((6.0, 6.0))
    fig.set_layout_engine(None)
    corner.corner(s, fig=fig, labels=["Δ (mm)", "d (mm)", "σ (1/m)"], truths=marks,
                  quantiles=[0.025, 0.5, 0.975], show_titles=True, title_fmt=".3g",
                  title_kwargs={"fontsize": 9}, label_kwargs={"fontsize": 10})
    path = Path(path)
    fig.savefig(path, dpi=110)
    return path
