"""The calibrated length map's table: simulated specimens at the calibration's L, and its disk cache.

For a handful of simulated rest lengths l* the specimen of
:mod:`airmat.check.validation` (parallel chained strings on a strip) is inflated and
its κ₁ measured as the calibration measures a specimen: circles fitted to
the cross-sections of the string face (:func:`~airmat.check.validation.specimen_kappa`),
as a cylinder fit of a scan reads it (the calibrated curve is Equation 3 fitted
to such fits). Each simulated κ₁ is then read back
through the calibrated Equation 3 (posterior median Δ, d): the real length l
that bends the real mattress to that κ₁. The rows (l, l*) are the table of
:class:`CalibratedLengthMap` (defined here, used through
:func:`airmat.check.length_map.length_map`); a last row (L − 2Δ, L) joins
the two flat lengths. The table is cached per (airmat version, L, Δ, d,
mattress thickness, resolution, simulator parameters, specimen layout) under
``$AIRMAT_CACHE`` (default ``~/.cache/airmat``), written atomically, so the
second use runs no simulation. SI units inside, mm in the cache file.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from airmat.errors import InputError

__all__ = ["CalibratedLengthMap", "calibrated_length_map", "specimen_table", "cache_dir", "N_ROWS"]

log = logging.getLogger(__name__)

#: simulated specimens per table
N_ROWS = 8
#: the table's longest simulated rest length, as a fraction of L (the last row, L itself, is not simulated)
_TOP = 0.97


@dataclass(frozen=True)
class CalibratedLengthMap:
    """Real string length -> simulated rest length through a table of simulated specimens (m).

    Between the table's rows the map is a monotone cubic (PCHIP) of l_sim / L
    over l / L, and its inverse that cubic's exact inverse (bisection). Outside
    the table each end continues with slope 1 (a constant end slip, l* = l + s
    with s the end row's l_sim − l; the last row is Equation 3's flat length
    L − 2Δ at the simulator's flat length L, so above the table s = 2Δ), and
    says so in the log.

    Attributes
    ----------
    L : float
        String spacing of the specimens (m).
    l_real, l_sim : ndarray of shape (n,)
        The table, both strictly increasing (m).
    delta : float
        Δ (m) of the calibration median the table reproduces.
    d : float
        Equation 3's d (m) of the calibration median.
    resolution, thickness : float
        Mesh edge length and mattress thickness (m) the specimens were simulated at.
    """

    L: float
    l_real: np.ndarray
    l_sim: np.ndarray
    delta: float
    d: float
    resolution: float
    thickness: float

    def __post_init__(self):
        r, s = np.asarray(self.l_real, float), np.asarray(self.l_sim, float)
        if r.ndim != 1 or r.shape != s.shape or r.size < 2:
            raise InputError(f"length table: expected two arrays of shape (n,), n >= 2; got {r.shape} and {s.shape}")
        if not (np.all(np.diff(r) > 0) and np.all(np.diff(s) > 0)):
            raise InputError("length table: real and simulated lengths must both increase strictly",
                             l_real=r, l_sim=s)
        object.__setattr__(self, "l_real", r)
        object.__setattr__(self, "l_sim", s)

    def _forward(self, x):
        from scipy.interpolate import PchipInterpolator

        return PchipInterpolator(self.l_real / self.L, self.l_sim / self.L, extrapolate=False)(x / self.L) * self.L

    def _outside(self, x, xs, ys, inside, what):
        """``inside`` where x lies in [xs[0], xs[-1]], else the end rows continued with slope 1."""
        lo, hi = x < xs[0], x > xs[-1]
        if lo.any() or hi.any():
            log.info("%d %s length(s) outside the calibrated table [%.1f, %.1f] mm: continued with a constant "
                     "end slip", int(lo.sum() + hi.sum()), what, xs[0] * 1e3, xs[-1] * 1e3)
        return np.where(hi, x + (ys[-1] - xs[-1]), np.where(lo, x + (ys[0] - xs[0]), inside))

    def to_simulated(self, l) -> np.ndarray:
        """Simulated rest lengths (m) of real lengths ``l`` (m), any shape, monotone.

        Examples
        --------
        >>> m = CalibratedLengthMap(0.3, np.array([0.1, 0.264]), np.array([0.16, 0.3]), 0.018, 0.07, 0.04, 0.07)
        >>> m.to_simulated([0.1, 0.264, 0.28]).round(4).tolist()
        [0.16, 0.3, 0.316]
        """
        l = np.asarray(l, float)
        return self._outside(l, self.l_real, self.l_sim, self._forward(l), "real")

    def to_real(self, l_sim) -> np.ndarray:
        """Real lengths (m) whose simulated rest length is ``l_sim`` (m): the inverse of :meth:`to_simulated`.

        Examples
        --------
        >>> m = CalibratedLengthMap(0.3, np.array([0.1, 0.264]), np.array([0.16, 0.3]), 0.018, 0.07, 0.04, 0.07)
        >>> bool(np.allclose(m.to_real(m.to_simulated([0.05, 0.2, 0.29])), [0.05, 0.2, 0.29]))
        True
        """
        l_sim = np.asarray(l_sim, float)
        # the exact inverse of the monotone cubic: bisection inside the row interval that holds l_sim
        # (a PCHIP of the swapped rows would differ from the inverse between the rows)
        i = np.clip(np.searchsorted(self.l_sim, l_sim) - 1, 0, self.l_sim.size - 2)
        lo, hi = self.l_real[i], self.l_real[i + 1]
        for _ in range(60):                        # 2^-60 of a row interval: below a nanometre
            mid = 0.5 * (lo + hi)
            below = self._forward(mid) < l_sim
            lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
        return self._outside(l_sim, self.l_sim, self.l_real, 0.5 * (lo + hi), "simulated")


def cache_dir() -> Path:
    """The cache folder: ``$AIRMAT_CACHE`` or ``~/.cache/airmat``."""
    return Path(os.environ.get("AIRMAT_CACHE") or Path.home() / ".cache" / "airmat")


def _grid(L, delta, d, thickness, n):
    """Rest lengths l* (m) to simulate: from what Equation 3 (Δ = 0, d = thickness) gives for the
    calibrated κ₁ at l = L/4, up to 0.97 L (the simulator bends more than Equation 3 at short l,
    so the shortest row lands below L/4)."""
    from airmat.calib.model import kappa1, string_length

    k_lo = kappa1(0.25 * L, L, delta, d)
    lo = float(string_length(np.minimum(k_lo, 0.999 * kappa1(0.0, L, 0.0, thickness)), L, 0.0, thickness))
    lo = min(max(lo, 0.3 * L), 0.8 * L)
    return np.linspace(lo, _TOP * L, n)


def specimen_table(*, L, delta, d, thickness, resolution, params=None, workers=1, n=N_ROWS):
    """Simulate the specimens and build the (real l, simulated l*) table (m).

    Parameters
    ----------
    L, delta, d : float
        String spacing, and the calibration median's Δ and d of Equation 3 (m).
    thickness : float
        Mattress thickness of the simulated specimen (m).
    resolution : float
        Mesh edge length (m).
    params : airmat.inflation.model.Parameters, optional
    workers : int
    n : int
        Simulated rest lengths.

    Returns
    -------
    l_real, l_sim, kappa : ndarray of shape (m,)
        The table (m, both increasing) and the simulated κ₁ of each row (1/m); the
        last row is (L − 2Δ, L, 0). Rows whose run did not converge, whose κ₁ does not
        decrease with l*, or beyond the calibrated Equation 3's reach are left out (logged).
    """
    from airmat.calib.model import kappa_max, string_length
    from airmat.check.validation import SpecimenLayout, specimen_kappa

    layout = SpecimenLayout(L=L, thickness=thickness)
    l_sim = _grid(L, delta, d, thickness, n)
    kappa, converged = specimen_kappa(l_sim, layout=layout, resolution=resolution, params=params, workers=workers)
    keep = converged & (kappa > 0) & (kappa < kappa_max(L, delta, d))
    # κ₁ must fall as l* grows: keep the rows below every shorter row's κ₁
    keep &= kappa < np.minimum.accumulate(np.concatenate([[np.inf], np.where(keep, kappa, np.inf)[:-1]]))
    if (~keep).any():
        log.warning("calibrated length map: %d of %d specimens left out (not converged, not monotone or beyond "
                    "Equation 3's reach) at l*/L = %s", int((~keep).sum()), n,
                    ", ".join(f"{x:.2f}" for x in l_sim[~keep] / L))
    l_real = string_length(kappa[keep], L, delta, d)
    l_real = np.append(l_real, L - 2 * delta)
    return l_real, np.append(l_sim[keep], L), np.append(kappa[keep], 0.0)


def _key(**values) -> tuple[str, dict]:
    from airmat import __version__

    key = {"airmat": __version__, **values}
    return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:20], key


def calibrated_length_map(*, L, delta, d, thickness, resolution, params=None, workers=1, cache=True):
    """The :class:`CalibratedLengthMap` of a calibration median, from the cache or simulated.

    Parameters
    ----------
    L, delta, d : float
        The calibration's string spacing and its median Δ, d (m).
    thickness : float
        Mattress thickness (m).
    resolution : float
        Mesh edge length (m): build the map at the resolution of the check that uses it.
    params : airmat.inflation.model.Parameters, optional
    workers : int
    cache : bool
        Read and write ``cache_dir() / "length_map"``.

    Returns
    -------
    CalibratedLengthMap
    """
    from airmat.atomic import atomic_write_text
    from airmat.check.validation import SpecimenLayout
    from airmat.inflation.model import Parameters

    params = Parameters() if params is None else params
    mm = {name: round(float(v) * 1e3, 6) for name, v in
          (("L_mm", L), ("delta_mm", delta), ("d_mm", d), ("thickness_mm", thickness), ("resolution_mm", resolution))}
    digest, key = _key(**mm, params=repr(params), rows=N_ROWS, top=_TOP, layout=repr(SpecimenLayout()),
                       measure="sections")
    path = cache_dir() / "length_map" / f"{digest}.json"
    table = None
    if cache and path.is_file():
        try:
            doc = json.loads(path.read_text())
            if doc["key"] == key:
                table = np.array(doc["l_real_mm"]) * 1e-3, np.array(doc["l_sim_mm"]) * 1e-3
                log.info("calibrated length map from the cache %s", path)
        except (OSError, ValueError, KeyError) as err:
            log.warning("ignoring the unreadable cache file %s: %s", path, err)
    if table is None:
        log.info("calibrated length map: simulating %d specimens at L = %.0f mm, %.0f mm resolution",
                 N_ROWS, L * 1e3, resolution * 1e3)
        l_real, l_sim, kappa = specimen_table(L=L, delta=delta, d=d, thickness=thickness, resolution=resolution,
                                              params=params, workers=workers)
        table = l_real, l_sim
        if cache:
            path.parent.mkdir(parents=True, exist_ok=True)
            atomic_write_text(path, json.dumps({"key": key, "l_real_mm": (l_real * 1e3).tolist(),
                                                "l_sim_mm": (l_sim * 1e3).tolist(),
                                                "kappa_per_m": kappa.tolist()}, indent=1) + "\n")
    return CalibratedLengthMap(L=float(L), l_real=table[0], l_sim=table[1], delta=float(delta), d=float(d),
                               resolution=float(resolution), thickness=float(thickness))
