"""The readers' common result: coordinates as the file stores them, and what the file says about them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["RawCloud", "library_message"]


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
        The unit the format prescribes ("m" for E57; LAS/LAZ in their
        CRS's unit, metres unless it says feet), None when it says nothing.
    n_scans : int
        Scans in the file (E57 may hold several).
    """

    vertices: np.ndarray
    faces: np.ndarray | None = None
    float32: bool = False
    units: str | None = None
    n_scans: int = 1


def library_message(err: BaseException, limit: int = 120) -> str:
    """A library exception as a short phrase: its type and the first sentence of its text."""
    text = str(err).strip().split("\n")[0].split(" ****")[0]
    if len(text) > limit:
        text = text[:limit - 3] + "..."
    return f"{type(err).__name__}: {text}" if text else type(err).__name__
