"""Stiffnesses of U_B in nondimensional form, and the assembled :class:`~airmat.inflation.energy.Model`.

Every stiffness is a multiple of a *reference* pressure ``p0`` (a material
constant, not the inflation pressure ``p``) times lengths of the problem
(thickness d, mesh spacing a), with a nondimensional coefficient:

- B1 membrane edges, ``k1 = c1 p0 d`` (c1 = 200). An edge of length a
  carries the face tension T ~ p d / 2 over a width a: tensile strain
  T / k1 = p / (2 c1 p0) = 2.5e-3 at p = p0 -- nearly inextensible.
  In compression the stiffness drops to ``c k1`` (c = 1e-2) over a strain
  of ``2 w`` (w = 5e-4): a wrinkling (tension-field) membrane, which lets the
  concave face shorten without resolving its folds. The paper's B1 keeps
  lengths both ways, so a bend must fold the concave face into the mattress
  (its Fig. 2/4 wrinkle), a few mesh edges deep. That literal variant is
  ``Parameters(compression=1, pin_compression=0)`` (pins that go slack where
  the face folds in). Measured with the same solver: vault1 at 50 mm, 181
  Newton iterations vs 54 and 45.6 mm RMS deviation from Ŝ vs 26.4 mm;
  the specimen strip at l/L = 0.5, 40 mm: 580 iterations vs ~60, κ along
  the strings 9.1 vs 8.3 1/m (Equation 3 with Δ = 0: 6.6 1/m).
- B3 loop pins, ``k3 = c3 p0 a² / d`` (c3 = 1e3): each pin holds p a²,
  strain p / (c3 p0) = 1e-3. Two-sided (the paper's Length goal) by default.
- B4 strings, axial stiffness ``E A = c4 p0 d²`` (c4 = 1e3), ``k4 = E A / l*``:
  tension-only with a smooth onset (clamp_width = 2.5e-4 of the length).
- B5 smoothing, ``k5 = c5 p0 d³ / a²`` (c5 = 5): ``1/2 k5 |x_i - x_i,avg|²``
  over the interior vertices of each face (cotangent weights of the flat
  mesh, so it is exactly 0 at rest and rigid-motion invariant). Since
  ``|x_i - x_i,avg| ~ a² κ / 4``, its energy density is ``k5 a² κ² / 32``
  per face: a bending stiffness ``EI ~ c5 p0 d³ / 16`` independent of the
  resolution. A wrinkling membrane alone has no bending stiffness and the
  bend then localises into kinks at arbitrary places (non-unique, and the
  solver stalls); c5 = 5 keeps the bend smooth. It is not negligible: at
  κ = 5 1/m both faces carry ~2 N m/m, ~40 % of the moment p0 d² / 2 at which
  a face goes slack; but the strings are ~10³ times stiffer axially, so their
  lengths still set the shape (on vault1 they end within 0.35 % of l*).
  Measured on vault1 at 50 mm: RMS deviation from Ŝ 32.6 / 26.4 / 25.0 mm
  for c5 = 2.5 / 5 / 10.

The inflated shape therefore barely depends on the actual pressure ``p``
(strains scale with p / p0; vault1 at 50 mm: 26.2 / 26.4 / 27.5 mm RMS
deviation at p = 1 / 2 / 4 kPa; tested).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from airmat.inflation.energy import Model, Springs, smoothing_matrix
from airmat.inflation.mesh import MattressMesh
from airmat.inflation.strings import StringSet, attach_strings, internal_strings

__all__ = ["Parameters", "build_model", "stiffnesses", "with_strings"]


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
    compression : float
        Stiffness ratio of a membrane edge in compression (1: the literal
        two-sided B1 of Equation 5).
    wrinkle_width : float
        Strain over which a membrane edge switches to its compression stiffness.
    pin_compression : float
        Stiffness ratio of a pin shorter than d (1: two-sided, 0: a slack string).
    """

    pressure: float = 2000.0
    reference_pressure: float = 2000.0
    membrane: float = 200.0
    pins: float = 1e3
    strings: float = 1e3
    smoothing: float = 5.0
    pin_every: int = 1
    clamp_width: float = 2.5e-4
    compression: float = 1e-2
    wrinkle_width: float = 5e-4
    pin_compression: float = 1.0


def stiffnesses(mesh: MattressMesh, params: Parameters) -> dict:
    """The spring constants (N/m) k1, k3, k5 and the string axial stiffness EA (N)."""
    p0, d = params.reference_pressure, mesh.thickness
    a = float(np.mean(mesh.spacing))
    return {"k1": params.membrane * p0 * d, "k3": params.pins * p0 * a * a / d,
            "EA4": params.strings * p0 * d * d, "k5": params.smoothing * p0 * d ** 3 / a ** 2}


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
        groups.append(_string_springs(mesh, strings, params, k))
    q = smoothing_matrix(mesh.uv[mesh.top], mesh.grid_faces, mesh.top, mesh.bottom, mesh.n_vertices, k["k5"])
    return Model(n_vertices=mesh.n_vertices, faces=mesh.faces, springs=tuple(groups),
                 pressure=float(params.pressure), smoothing=q)


def _string_springs(mesh: MattressMesh, strings: StringSet, params: Parameters, k: dict):
    """Term B4: the external strings, of axial stiffness EA4 / l* each."""
    return attach_strings(mesh, strings, stiffness=k["EA4"] / np.maximum(strings.rest, mesh.thickness),
                          smooth=params.clamp_width)


def with_strings(model: Model, mesh: MattressMesh, strings: StringSet, params: Parameters = Parameters()) -> Model:
    """``model`` (built by :func:`build_model` on ``mesh`` with strings) with other external strings.

    The same as ``build_model(mesh, strings, params)``, but only term B4 is rebuilt: what a
    refinement needs at every trial of the rest lengths (the smoothing matrix alone costs
    tens of ms on the large mattress).

    Parameters
    ----------
    model : Model
        Built on ``mesh`` with ``params`` and a non-empty string set.
    mesh : MattressMesh
    strings : StringSet
        The new strings (rest lengths l*, m).
    params : Parameters
    """
    if len(model.springs) < 3 or model.springs[-1].name != "B4":
        raise ValueError("with_strings: the model has no external strings to replace")
    return replace(model, springs=model.springs[:-1] + (_string_springs(mesh, strings, params,
                                                                         stiffnesses(mesh, params)),))
