"""Stiffnesses of U_B in nondimensional form, and the assembled :class:`~design.inflation.energy.Model`.

Every stiffness is a multiple of a *reference* pressure ``p0`` times a length
of the problem, chosen so that each element's strain under its pressure load
is about ``1 / c`` (``c`` the nondimensional coefficient, default 1e3):

- B1 edges: ``k1 = c1 p0 d``. An edge of length a carries the face tension
  T ~ p d / 2 (the side band holds the two faces together) over a width a:
  strain = T a / (k1 a) = p / (2 c1 p0) ~ 5e-4.
- B3 pins: ``k3 = c3 p0 a² / d``. A pin holds the pressure on its cell,
  p a²: strain = p a² / (k3 d) = p / (c3 p0) ~ 1e-3.
- B4 strings: ``k4 = c4 p0 d² / l*`` (axial stiffness E A = c4 p0 d²). A
  string balances the pressure moment on its strip, F ~ p d μ2 with
  μ2 ~ 0.1 m: strain ~ 1.4e-3.
- B5 smoothing: ``k5 = c5 p0 a``, c5 = 1e-2: the Laplacian force of a
  bend κ, ~ k5 a² κ, is ~ c5 a κ ≈ 2e-3 of the pressure force p a² per
  vertex at κ = 6 /m -- a regulariser of the folds, not a bending stiffness.

The membrane is therefore nearly inextensible at the reference pressure, and
the inflated shape barely depends on the actual pressure ``p``: doubling it
doubles the strains (still ~1e-3) but not the geometry (tested).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from design.inflation.energy import Model, Springs, smoothing_matrix
from design.inflation.mesh import MattressMesh
from design.inflation.strings import StringSet, attach_strings, internal_strings

__all__ = ["Parameters", "build_model", "stiffnesses"]


@dataclass(frozen=True)
class Parameters:
    """Pressure (Pa) and nondimensional stiffness coefficients of U_B.

    Attributes
    ----------
    pressure : float
        p (Pa), default 2 kPa (a drop-stitch mattress at a few kPa).
    reference_pressure : float
        p0 (Pa) the stiffnesses are scaled by (fixed material, not p).
    membrane, pins, strings, smoothing : float
        c1, c3, c4, c5 (see the module docstring).
    pin_every : int
        A loop pin at every ``pin_every``-th grid point (1: every vertex).
    clamp_width : float
        Smoothed slack/taut onset of the pins and strings, relative to their
        rest length (a quarter of their strain under load).
    """

    pressure: float = 2000.0
    reference_pressure: float = 2000.0
    membrane: float = 200.0
    pins: float = 1e3
    strings: float = 1e3
    smoothing: float = 1e-2
    pin_every: int = 1
    clamp_width: float = 2.5e-4
    compression: float = 1e-3
    wrinkle_width: float = 1e-3
    pin_compression: float = 1.0


def stiffnesses(mesh: MattressMesh, params: Parameters) -> dict:
    """The spring constants (N/m) k1, k3, k5 and the string axial stiffness EA (N)."""
    p0, d = params.reference_pressure, mesh.thickness
    a = float(np.mean(mesh.spacing))
    return {"k1": params.membrane * p0 * d, "k3": params.pins * p0 * a * a / d,
            "EA4": params.strings * p0 * d * d, "k5": params.smoothing * p0 * a}


def build_model(mesh: MattressMesh, strings: StringSet | None, params: Parameters = Parameters()) -> Model:
    """Assemble U_B for a mattress mesh and its external strings.

    Parameters
    ----------
    mesh : MattressMesh
        M′ at rest (its vertices give the B1 rest lengths).
    strings : StringSet or None
        External strings, rest lengths l* (m).
    params : Parameters

    Returns
    -------
    Model
    """
    k = stiffnesses(mesh, params)
    e = mesh.edges
    rest = np.linalg.norm(mesh.vertices[e[:, 1]] - mesh.vertices[e[:, 0]], axis=1)
    groups = [Springs(idx=e, coef=np.tile([-1.0, 1.0], (len(e), 1)), rest=rest,
                      stiffness=np.full(len(e), k["k1"]), compression=params.compression, name="B1",
                      smooth=params.wrinkle_width * rest),
              internal_strings(mesh, stiffness=k["k3"], every=params.pin_every,
                               compression=params.pin_compression, smooth=params.clamp_width)]
    if strings is not None and len(strings):
        groups.append(attach_strings(mesh, strings,
                                     stiffness=k["EA4"] / np.maximum(strings.rest, mesh.thickness),
                                     smooth=params.clamp_width))
    q = smoothing_matrix(mesh.grid_faces, mesh.top, mesh.bottom, mesh.n_vertices, k["k5"])
    return Model(n_vertices=mesh.n_vertices, faces=mesh.faces, springs=tuple(groups),
                 pressure=float(params.pressure), smoothing=q)
