"""The flat mattress Ω = [0, W] × [0, H] and its triangulation.

Ω's triangulation is the mesh that the U_A relaxation bends into Ŝ: Ŝ and
Ω share its connectivity, so every vertex keeps its position on Ω. Lengths
are in metres.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from airmat.constants import PAPER_D
from airmat.errors import InputError
from airmat.geometry.grid import cell_count, rectangle_grid

__all__ = ["Mattress", "triangulate_mattress", "check_spacing", "MAX_VERTICES"]

log = logging.getLogger(__name__)

#: more vertices than this is a spacing slip (mm read as m), or beyond what the relaxation's sparse
#: solver handles in memory (614k vertices, 1 mm on 830 x 740 mm, failed in SuperLU under 6 GB)
MAX_VERTICES = 100_000


@dataclass(frozen=True)
class Mattress:
    """A rectangular drop-stitch mattress.

    Parameters
    ----------
    width, height : float
        W and H of Ω (m); Ω = [0, W] × [0, H], top face seen from above.
    thickness : float, default 0.07
        Inflated thickness d (m); the paper's mattresses are 70 mm thick.

    Raises
    ------
    airmat.errors.InputError
        For a non-finite or non-positive size.
    """

    width: float
    height: float
    thickness: float = PAPER_D

    def __post_init__(self):
        for name in ("width", "height", "thickness"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float, np.floating, np.integer))
                    and math.isfinite(value) and value > 0):
                raise InputError(f"mattress {name} must be a finite length > 0 m, got {value!r}",
                                 **{name: value})

    @property
    def diagonal(self) -> float:
        """Length (m) of Ω's diagonal."""
        return math.hypot(self.width, self.height)

    @property
    def size_mm(self) -> str:
        """``"830 × 740 mm"``: the size for messages."""
        return f"{self.width * 1e3:.0f} × {self.height * 1e3:.0f} mm"


def check_spacing(mattress: Mattress, spacing: float) -> tuple[int, int]:
    """The cells across and along Ω at ``spacing`` (m); InputError when the mesh would be unusable.

    Raises
    ------
    airmat.errors.InputError
        For a spacing that is not a positive length, leaves fewer than two
        cells across Ω, or makes more than :data:`MAX_VERTICES` vertices.

    Examples
    --------
    >>> check_spacing(Mattress(0.83, 0.74), 0.02)
    (42, 37)
    """
    if not (math.isfinite(spacing) and spacing > 0):
        raise InputError(f"mesh spacing must be a finite length > 0 m, got {spacing!r}", spacing=spacing)
    nu_cells = cell_count(mattress.width, spacing)
    nv_cells = cell_count(mattress.height, spacing)
    if min(nu_cells, nv_cells) < 2:
        raise InputError(f"mesh spacing {spacing * 1e3:.0f} mm leaves fewer than 2 cells across the "
                         f"{mattress.size_mm} mattress", spacing=spacing)
    if (nu_cells + 1) * (nv_cells + 1) > MAX_VERTICES:
        raise InputError(f"mesh spacing {spacing * 1e3:.3g} mm gives "
                         f"{(nu_cells + 1) * (nv_cells + 1)} vertices on the {mattress.size_mm} mattress, "
                         f"limit {MAX_VERTICES}: choose a coarser spacing (a unit slip?)", spacing=spacing)
    return nu_cells, nv_cells


def triangulate_mattress(mattress: Mattress, *, spacing: float = 0.02):
    """Triangulate Ω with a regular grid of alternating diagonals (:mod:`airmat.geometry.grid`).

    The grid has ``ceil(W / spacing)`` × ``ceil(H / spacing)`` cells (so the
    actual spacing is at most ``spacing``, slightly smaller when W or H is
    not a multiple). Cell (i, j) is split along the diagonal whose direction
    alternates like a chequerboard, so the mesh has no preferred diagonal
    direction and every interior vertex's neighbours are centrally
    symmetric: the umbrella (U_A3) term vanishes on the flat Ω.

    Parameters
    ----------
    mattress : Mattress
    spacing : float, default 0.02
        Largest grid spacing (m).

    Returns
    -------
    uv : ndarray of shape (n, 2)
        Vertex positions on Ω (m), row-major: ``uv[j * nu + i]`` is grid point (i, j).
    faces : ndarray of shape (m, 3)
        Triangles (int64), counter-clockwise seen from above (normal +z: the top normal).

    Raises
    ------
    airmat.errors.InputError
        For a spacing that is not a positive length, leaves fewer than two
        cells across Ω, or makes more than :data:`MAX_VERTICES` vertices.

    Examples
    --------
    >>> uv, faces = triangulate_mattress(Mattress(0.83, 0.74), spacing=0.02)
    >>> uv.shape, faces.shape
    ((1634, 2), (3108, 3))
    """
    nu_cells, nv_cells = check_spacing(mattress, spacing)
    uv, faces = rectangle_grid(mattress.width, mattress.height, nu_cells + 1, nv_cells + 1,
                               diagonals="alternating")
    log.debug("Ω triangulated: %d vertices, %d faces, spacing %.1f mm",
              len(uv), len(faces), 1e3 * max(mattress.width / nu_cells, mattress.height / nv_cells))
    return uv, faces
