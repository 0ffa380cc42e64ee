"""The paper's cylindrical-specimen experiment, simulated: realized κ against Equation 3.

A strip of mattress carries rows of strings along u, each of span L between
its ends, chained end to end and staggered by L/2 between neighbouring rows
(the designer's stagger). For each ratio l/L the strip is inflated with
string rest length l (Δ = 0: the simulated ends do not slip) and the
curvature of the simulated mid-surface over the strip's middle is measured
with calib's own robust cylinder fit. Equation 3 with Δ = 0 and d = the
thickness is the model to compare with. SI units.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from airmat.constants import PAPER_D, PAPER_L
from airmat.errors import NotACylinderError
from airmat.figures import new_figure
from calib.cylinder_fit import fit_cylinder
from calib.model import kappa1
from check.compare import realized_curvature, surface_at
from inflation.mesh import build_mattress_mesh
from inflation.model import Parameters
from inflation.simulate import inflate_many
from inflation.strings import StringSet

__all__ = ["SpecimenLayout", "specimen_strings", "ValidationPoint", "validate_equation3", "validation_figure"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SpecimenLayout:
    """The simulated specimen (m): ``n_series`` strings of span L along u per row, rows ``row_spacing`` apart."""

    L: float = PAPER_L
    n_series: int = 3
    n_rows: int = 4
    row_spacing: float = 0.100
    margin: float = 0.050
    thickness: float = PAPER_D

    @property
    def width(self) -> float:
        return (self.n_series + 0.5) * self.L + 2 * self.margin

    @property
    def height(self) -> float:
        return (self.n_rows - 1) * self.row_spacing + 2 * self.margin


def specimen_strings(layout: SpecimenLayout, l: float) -> StringSet:
    """Strings of rest length ``l`` on the bottom face (the strip bends away from the top: κ > 0)."""
    a, b = [], []
    for row in range(layout.n_rows):  # a handful of rows
        u0 = layout.margin + (0.5 * layout.L if row % 2 else 0.0)
        v = layout.margin + row * layout.row_spacing
        starts = u0 + layout.L * np.arange(layout.n_series)
        a.append(np.column_stack([starts, np.full(layout.n_series, v)]))
        b.append(np.column_stack([starts + layout.L, np.full(layout.n_series, v)]))
    a, b = np.concatenate(a), np.concatenate(b)
    return StringSet(a, b, np.zeros(len(a), bool), np.full(len(a), float(l)),
                     tuple(f"s{i:02d}" for i in range(len(a))))


@dataclass(frozen=True)
class ValidationPoint:
    """One simulated specimen (1/m): l/L; κ of a cylinder fitted to the mid-surface over the middle
    2L of the strip; Equation 3's κ; and the mean realized κ along the strings (circle through each
    string's two ends and its middle on the mid-surface: the polygon model of the paper's Figure 4)."""

    l_over_L: float
    kappa_sim: float
    kappa_sim_se: float
    kappa_eq3: float
    kappa_strings: float
    converged: bool
    n_iter: int
    seconds: float
    message: str


def _measure(inf, layout: SpecimenLayout, seed: int):
    """Fit a cylinder to the mid-surface over the middle span (one L either side of the centre)."""
    u = np.linspace(0.5 * layout.width - layout.L, 0.5 * layout.width + layout.L, 121)
    v = np.linspace(layout.margin, layout.height - layout.margin, 31)
    uv = np.stack(np.meshgrid(u, v), axis=-1).reshape(-1, 2)
    mid, _ = surface_at(inf, uv)
    return fit_cylinder(mid, seed=seed, remove_support=False, max_rms_rel=0.02, max_rms_ratio=1e3)


def validate_equation3(ratios=(0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9), *, layout: SpecimenLayout = SpecimenLayout(),
                       resolution: float = 0.04, params: Parameters = Parameters(), seed: int = 0,
                       workers: int = 1):
    """Simulate the specimen for each l/L and measure its curvature.

    Parameters
    ----------
    ratios : sequence of float
        The l/L to simulate.
    layout : SpecimenLayout
    resolution : float
        Mesh edge length (m).
    params : Parameters
    seed : int
        Seed of the cylinder fit.
    workers : int
        Processes for the inflations (see :func:`~inflation.simulate.inflate_many`).

    Returns
    -------
    list of ValidationPoint
    """
    mesh = build_mattress_mesh(layout.width, layout.height, layout.thickness, resolution=resolution)
    inflations = inflate_many(mesh, [specimen_strings(layout, float(r) * layout.L) for r in ratios],
                              params=params, workers=workers, desc="validate")
    points = []
    for r, inf in zip(ratios, inflations):
        l = float(r) * layout.L
        try:
            fit = _measure(inf, layout, seed)
            k, se = fit.kappa, fit.kappa_se
        except NotACylinderError as err:
            log.warning("l/L = %.2f: the simulated strip is not cylindrical enough to fit: %s", r, err)
            k, se = float("nan"), float("nan")
        k3 = float(kappa1(l, layout.L, 0.0, layout.thickness))
        strings = specimen_strings(layout, l)
        ks = realized_curvature(inf, strings.a, strings.b, [np.stack(ab) for ab in zip(strings.a, strings.b)])
        log.info("l/L = %.2f: simulated %.2f 1/m (cylinder fit), %.2f 1/m (along strings); Equation 3 "
                 "(Delta = 0) %.2f 1/m", r, k, float(np.mean(ks)), k3)
        points.append(ValidationPoint(float(r), float(k), float(se), k3, float(np.mean(ks)), inf.converged, inf.n_iter,
                                      inf.seconds, inf.message))
    return points


def validation_figure(points, *, layout: SpecimenLayout = SpecimenLayout()):
    """Simulated κ against l/L next to Equation 3 (Δ = 0): the figure of ``airmat validate``.

    Parameters
    ----------
    points : sequence of ValidationPoint
        As returned by :func:`validate_equation3` for ``layout``.
    layout : SpecimenLayout
        Its L and thickness d give the Equation-3 curve and the labels.

    Returns
    -------
    matplotlib.figure.Figure
    """
    L_mm, d_mm = layout.L * 1e3, layout.thickness * 1e3
    grid = np.linspace(0, 1, 201)
    fig = new_figure((6.5, 4.5))
    ax = fig.subplots()
    ax.plot(grid, kappa1(grid * layout.L, layout.L, 0.0, layout.thickness), "k-",
            label=f"Equation 3, Δ = 0, d = {d_mm:g} mm")
    ax.errorbar([p.l_over_L for p in points], [p.kappa_sim for p in points],
                yerr=[2 * p.kappa_sim_se for p in points], fmt="o", color="C3",
                label="simulated: cylinder fit of the mid-surface")
    ax.plot([p.l_over_L for p in points], [p.kappa_strings for p in points], "s", color="C0",
            label="simulated: circle through each string's ends and middle (mean)")
    ax.set_xlabel(f"string length ratio l / L (L = {L_mm:g} mm)")
    ax.set_ylabel("curvature κ₁ (1/m)")
    ax.grid(alpha=0.3)
    ax.legend()
    ax.set_title("airmat validate: inflation simulation against Equation 3")
    fig.tight_layout()
    return fig
