"""Principal-curvature fields carried onto the flat mattress Ω.

:class:`MattressField` is the hand-over between the two halves of the
designer: the surface side (relaxation to Ŝ, curvature, transfer through
the per-triangle map f: Ŝ -> Ω) produces it, the pattern side (stripe
tracer, string lengths) consumes it. Everything is in SI: metres on Ω,
1/m for curvature.

Conventions (see CONTRIBUTING.md): curvatures are signed against the top
normal (κ > 0 bends away from it, the string goes on the bottom face);
family 0 (``k1``) is the algebraically larger principal curvature when the
design bends mostly positively, else the smaller
(airmat.design.transfer.family_order): on a saddle each family has one sign
and keeps to one face; where both curvatures have the design's main sign it
is the curvature of larger magnitude;
directions are *lines* on Ω (the sign of a direction vector means nothing),
so they are interpolated in the doubled-angle representation.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from scipy.interpolate import LinearNDInterpolator

__all__ = ["MattressField", "FAMILIES"]

FAMILIES = ("k1", "k2")


@dataclass(frozen=True)
class MattressField:
    """Curvature magnitudes and principal line fields on Ω = [0, W] × [0, H].

    Parameters
    ----------
    width, height : float
        W and H of the mattress (m).
    uv : ndarray of shape (n, 2)
        Sample positions on Ω (m), e.g. the vertices of Ω's triangulation.
    kappa : ndarray of shape (n, 2)
        Signed principal curvatures (1/m) at ``uv``: column 0 the family
        ``k1`` (airmat.design.transfer.family_order), column 1 ``k2``.
    direction : ndarray of shape (n, 2, 2)
        ``direction[:, i]`` is a unit vector on Ω along the principal
        direction of family i (a line: its sign is arbitrary).
    weight : ndarray of shape (n,)
        Reliability of the directions in [0, 1] (the anisotropy |κ1 - κ2|
        normalised); near 0 at umbilics, where directions mean nothing.
    """

    width: float
    height: float
    uv: np.ndarray
    kappa: np.ndarray
    direction: np.ndarray
    weight: np.ndarray
    meta: dict = field(default_factory=dict, compare=False)

    def __post_init__(self):
        n = len(self.uv)
        shapes = {"uv": (n, 2), "kappa": (n, 2), "direction": (n, 2, 2), "weight": (n,)}
        for name, shape in shapes.items():
            if np.shape(getattr(self, name)) != shape:
                raise ValueError(f"MattressField.{name} has shape {np.shape(getattr(self, name))}, "
                                 f"expected {shape}")

    @cached_property
    def _interp(self) -> LinearNDInterpolator:
        d = self.direction
        doubled = np.stack([d[..., 0] ** 2 - d[..., 1] ** 2, 2 * d[..., 0] * d[..., 1]], axis=-1)
        values = np.concatenate([self.kappa, doubled.reshape(len(self.uv), 4), self.weight[:, None]], axis=1)
        return LinearNDInterpolator(self.uv, values)

    def _sample(self, pts: np.ndarray) -> np.ndarray:
        pts = np.asarray(pts, dtype=float).reshape(-1, 2)
        eps = 1e-9 * max(self.width, self.height)
        pts = np.clip(pts, [eps, eps], [self.width - eps, self.height - eps])
        return self._interp(pts)

    def kappa_at(self, family: int, pts) -> np.ndarray:
        """Signed curvature (1/m) of ``family`` (0: k1, 1: k2) at points (k, 2) on Ω (m)."""
        return self._sample(pts)[:, family]

    def direction_at(self, family: int, pts) -> np.ndarray:
        """Unit line directions (k, 2) of ``family`` at points (k, 2) on Ω (m).

        Interpolated in the doubled-angle representation, so opposite vectors
        at neighbouring samples reinforce instead of cancelling.
        """
        s = self._sample(pts)[:, 2 + 2 * family: 4 + 2 * family]
        half = 0.5 * np.arctan2(s[:, 1], s[:, 0])
        return np.stack([np.cos(half), np.sin(half)], axis=1)

    def weight_at(self, pts) -> np.ndarray:
        """Direction reliability (k,) in [0, 1] at points (k, 2) on Ω (m)."""
        return self._sample(pts)[:, 6]

    def contains(self, pts, margin: float = 0.0) -> np.ndarray:
        """Boolean mask (k,) of points (k, 2) inside Ω shrunk by ``margin`` (m)."""
        p = np.asarray(pts, dtype=float).reshape(-1, 2)
        return ((p[:, 0] >= margin) & (p[:, 0] <= self.width - margin)
                & (p[:, 1] >= margin) & (p[:, 1] <= self.height - margin))
