"""External tension strings (B4) fixed on the faces of M′ by barycentric coordinates.

Each string end sits at a point of Ω (``a``, ``b``) on the top or the bottom
face; it is carried by the face triangle that contains the point, so
``x_end = sum_k w_k x_k`` over that triangle's three vertices and the
string is one six-vertex spring of :class:`airmat.inflation.energy.Springs`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from airmat.errors import InputError
from airmat.inflation.energy import Springs
from airmat.inflation.mesh import MattressMesh, locate

__all__ = ["StringSet", "attach_strings", "check_resolution", "internal_strings"]


@dataclass(frozen=True)
class StringSet:
    """External strings in Ω coordinates (SI).

    Attributes
    ----------
    a, b : ndarray of shape (k, 2)
        End points on Ω (m).
    top : ndarray of shape (k,), bool
        True for a string on the top face, False for the bottom face.
    rest : ndarray of shape (k,)
        Simulated rest length l* = l + 2 Δ (m).
    ids : tuple of str
        One id per string (for messages).
    """

    a: np.ndarray
    b: np.ndarray
    top: np.ndarray
    rest: np.ndarray
    ids: tuple = ()

    def __post_init__(self):
        k = len(self.a)
        for name, shape in (("a", (k, 2)), ("b", (k, 2)), ("top", (k,)), ("rest", (k,))):
            if np.shape(getattr(self, name)) != shape:
                raise ValueError(f"StringSet.{name} has shape {np.shape(getattr(self, name))}, "
                                 f"expected {shape}")

    def __len__(self) -> int:
        return len(self.a)

    def _id(self, i: int) -> str:
        return self.ids[i] if i < len(self.ids) else f"#{i}"


def check_resolution(strings: StringSet, resolution: float, *, per_string: float = 4.0) -> None:
    """Refuse a mesh too coarse for the strings: each needs >= ``per_string`` edges along it.

    Raises
    ------
    airmat.errors.InputError
        When ``resolution > L / per_string`` for the shortest string span L.
    """
    if len(strings) == 0:
        return
    span = np.linalg.norm(strings.b - strings.a, axis=1)
    i = int(np.argmin(span))
    if resolution > span[i] / per_string:
        raise InputError(f"resolution {resolution * 1e3:.4g} mm is too coarse for the strings: "
                         f"string {strings._id(i)} spans L = {span[i] * 1e3:.4g} mm, which needs a "
                         f"resolution <= L/{per_string:g} = {span[i] / per_string * 1e3:.4g} mm",
                         resolution=resolution, span=span[i])


def attach_strings(mesh: MattressMesh, strings: StringSet, *, stiffness: np.ndarray,
                   smooth: float = 0.0) -> Springs:
    """The external strings as clamp springs on the faces of ``mesh`` (term B4).

    Parameters
    ----------
    mesh : MattressMesh
    strings : StringSet
    stiffness : ndarray of shape (k,)
        Spring constant of each string (N/m).
    smooth : float
        Width of the smoothed slack/taut onset, relative to the rest length.

    Returns
    -------
    Springs
        Tension-only, six vertices per string: ``r = x(a) - x(b)``.

    Raises
    ------
    airmat.errors.InputError
        When an end lies outside Ω (names the string id).
    """
    ends = np.concatenate([strings.a, strings.b])
    tol = 1e-9 * max(mesh.width, mesh.height)
    outside = ((ends[:, 0] < -tol) | (ends[:, 0] > mesh.width + tol)
               | (ends[:, 1] < -tol) | (ends[:, 1] > mesh.height + tol) | ~np.isfinite(ends).all(1))
    if np.any(outside):
        i = int(np.flatnonzero(outside)[0]) % len(strings)
        raise InputError(f"string {strings._id(i)} has an end outside the "
                         f"{mesh.width * 1e3:.0f} x {mesh.height * 1e3:.0f} mm mattress "
                         f"(a = {np.round(strings.a[i] * 1e3, 1).tolist()} mm, "
                         f"b = {np.round(strings.b[i] * 1e3, 1).tolist()} mm)", string=strings._id(i))
    grid_tri, bary = locate(mesh, ends)
    face = np.where(np.tile(strings.top, 2)[:, None], mesh.top[grid_tri], mesh.bottom[grid_tri])
    k = len(strings)
    idx = np.concatenate([face[:k], face[k:]], axis=1)
    coef = np.concatenate([bary[:k], -bary[k:]], axis=1)
    return Springs(idx=idx, coef=coef, rest=np.asarray(strings.rest, float),
                   stiffness=np.broadcast_to(np.asarray(stiffness, float), (k,)).copy(),
                   compression=0.0, name="B4", smooth=smooth * np.maximum(strings.rest, mesh.thickness))


def internal_strings(mesh: MattressMesh, *, stiffness: float, every: int = 1, compression: float = 1.0,
                     smooth: float = 0.0) -> Springs:
    """Loop pins (term B3): springs of rest length d joining top[g] and bottom[g].

    Parameters
    ----------
    mesh : MattressMesh
    stiffness : float
        Spring constant of each pin (N/m).
    every : int
        Keep every ``every``-th grid point along u and v (1: all of them).
    compression : float
        Stiffness ratio when shorter than d: 1 keeps their length both ways
        (the Length goal of the paper), 0 lets them go slack.
    smooth : float
        Width of the smoothed slack/taut onset, relative to d.
    """
    nx, ny = mesh.grid_shape
    i, j = np.meshgrid(np.arange(0, nx, every), np.arange(0, ny, every), indexing="xy")
    g = (j * nx + i).ravel()
    idx = np.column_stack([mesh.top[g], mesh.bottom[g]])
    return Springs(idx=idx, coef=np.tile([1.0, -1.0], (len(g), 1)),
                   rest=np.full(len(g), mesh.thickness), stiffness=np.full(len(g), float(stiffness)),
                   compression=compression, name="B3", smooth=smooth * mesh.thickness)
