"""The readers' common result: coordinates as the file stores them, and what the file says about them."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

__all__ = ["RawCloud", "library_message", "check_step", "check_plausible", "MIN_STEPS_ACROSS"]

#: fewest steps of the stored coordinates across a scan: coarser grids leave no surface to fit
MIN_STEPS_ACROSS = 50


@dataclass(frozen=True)
class RawCloud:
    """A scan file's content before unit conversion and filtering.

    Attributes
    ----------
    vertices : ndarray of shape (N, 3)
        Coordinates in the file's unit, float64 (exact copies of float32
        values when the file stores float32); may hold NaN.
    faces : ndarray of shape (F, 3) or None
        Triangle vertex indices of a mesh, None for a point cloud.
    float32 : bool
        Whether the file stores the coordinates as 32-bit floats (their
        quantization step grows with the distance from the origin).
    units : str or None
        The unit the file states (a key of :data:`airmat.units.SCAN_UNITS`):
        the format's ("m" for E57; LAS/LAZ in their CRS's linear unit, metres
        when they name none), an exporter's comment (OBJ ``# File units =
        inches``, PLY ``comment Units: cm``); None when it says nothing.
    n_scans : int
        Scans in the file (E57 may hold several).
    step : float
        Step between the coordinates the file can store, in its unit: the
        scale of a format that stores integers (LAS/LAZ, E57 scaled
        integers), the spacing of 32-bit floats at the largest coordinate
        of an E57 scan (before its pose); 0 when ``float32`` says it or for
        float64.
    """

    vertices: np.ndarray
    faces: np.ndarray | None = None
    float32: bool = False
    units: str | None = None
    n_scans: int = 1
    step: float = 0.0


def library_message(err: BaseException, limit: int = 120) -> str:
    """A library exception as a short phrase: its type and the first sentence of its text."""
    text = str(err).strip().split("\n")[0].split(" ****")[0]
    if len(text) > limit:
        text = text[:limit - 3] + "..."
    return f"{type(err).__name__}: {text}" if text else type(err).__name__


def check_step(xyz: np.ndarray, step: float, path, what: str, fix: str, metres_per_unit: float = 1.0) -> None:
    """Raise InputError when a step of ``step`` (file units) leaves fewer than :data:`MIN_STEPS_ACROSS`
    values across the scan ``xyz`` (N, 3): ``what`` says how the file stores them, ``fix`` what to do."""
    from airmat.errors import InputError

    if not step > 0 or not len(xyz):
        return
    with np.errstate(invalid="ignore"):
        extent = float(np.linalg.norm(np.nanmax(xyz, axis=0) - np.nanmin(xyz, axis=0)))
    if np.isfinite(extent) and step * MIN_STEPS_ACROSS > extent:
        raise InputError(f"coordinates lost precision: {what}, steps of {_length(step * metres_per_unit)} "
                         f"across a scan {_length(extent * metres_per_unit)} wide leave no surface to fit; {fix}",
                         path=path, step=step)


def _length(metres: float) -> str:
    return f"{metres * 1e3:.3g} mm" if metres < 1 else f"{metres:.3g} m"


#: no scan coordinate is this large or this small (and nonzero), in any unit
_ABSURD = (1e15, 1e-30)
#: share of the points with absurd values that marks a damaged body (a few stray values are dropped)
_ABSURD_SHARE = 0.01


def check_plausible(cloud: RawCloud, path) -> RawCloud:
    """Refuse a cloud whose body is garbage; drop (as NaN) the few absurd values of an otherwise sound one.

    A damaged binary body, or one its header misdescribes, reads as float bit patterns spread over every
    exponent: 1e38 next to 1e-41. They are finite, so without this check they reach the arithmetic (where
    they overflow with a RuntimeWarning on stderr) and the fit (which refuses them for another reason).
    """
    from airmat.errors import InputError

    xyz = cloud.vertices
    size = np.abs(xyz)
    with np.errstate(invalid="ignore"):
        absurd = ((size > _ABSURD[0]) & np.isfinite(size)) | ((size < _ABSURD[1]) & (size > 0))
    bad = absurd.any(axis=1)
    n_bad = int(np.count_nonzero(bad))
    if not n_bad:
        return cloud
    if n_bad > _ABSURD_SHARE * len(xyz):
        examples = ", ".join(f"{v:.2g}" for v in np.unique(xyz[absurd])[[0, -1]])
        raise InputError(f"damaged file: {n_bad} of {len(xyz)} points hold values no coordinate has "
                         f"(such as {examples}): the body is corrupt, or the header does not describe it",
                         path=path, n_absurd=n_bad)
    xyz = xyz.copy()
    xyz[bad] = np.nan   # counted and reported with the other non-finite points
    return dataclasses.replace(cloud, vertices=xyz)
