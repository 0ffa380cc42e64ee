"""Benchmark: Ŝ relaxed with its edges softer in compression than in tension, and how close the open loop comes.

Usage::

    .venv/bin/python bench/bench_relax_compression.py                       # vault1 and the saddle, c = 1, 0.3, 0.1
    .venv/bin/python bench/bench_relax_compression.py --presets saddle --ratios 1,0.5

The inflated faces are membranes in tension: they wrinkle (shorten at almost
no cost) but hardly stretch. U_A's A1 term (airmat.design.local_global) holds every
edge of Ŝ to its rest length with one stiffness both ways. Here an edge
shorter than its rest length is held by ``c`` times that stiffness: the
energy ``½ k_A1 c (ε − ε0)²`` for ε < ε0, and the local step's target for such
an edge ``ε − c (ε − ε0)``, so that the fixed global matrix still majorizes the
energy (each iteration still lowers U_A). ``c = 1`` is the designer's U_A.
Each preset (paper calibration values, seed 0, defaults otherwise) is designed
with each ratio and inflated at its median lengths at 20 mm; the table gives
σ, Ŝ's RMS distance from the target S and the check's deviation of the named
face from Ŝ (``airmat inflate``). An experiment, not an option of the
designer: it says whether a Ŝ that may compress more freely is one the
mattress lands on more closely.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path
from unittest import mock

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import airmat.design.local_global as local_global  # noqa: E402
from airmat.design.closest_point import MeshProjector  # noqa: E402
from bench_family_gain import MM, floats, open_loop_cells  # noqa: E402
from designed_preset import designed_preset  # noqa: E402


def softer_in_compression(c: float):
    """U_A's A1 term with compressed edges ``c`` times as stiff (the energy and the local step's target)."""
    cls = local_global.UAProblem

    def energy(self, x, cp):
        k1, k2, k3 = self.k
        stretch = np.linalg.norm(self.inc @ x, axis=1) - self.rest
        u1 = 0.5 * k1 * np.sum(np.where(stretch < 0, c, 1.0) * stretch ** 2)
        u2 = 0.5 * k2 * np.sum((x - cp) ** 2)
        u3 = 0.5 * k3 * np.sum((self.lap @ x) ** 2)
        return {"U_A1": float(u1), "U_A2": float(u2), "U_A3": float(u3), "U_A": float(u1 + u2 + u3)}

    def global_step(self, x, cp):
        k1, k2, _ = self.k
        d = self.inc @ x
        length = np.linalg.norm(d, axis=1)
        stretch = length - self.rest
        target = np.where(stretch < 0, length - c * stretch, self.rest)
        d *= (target / np.maximum(length, 1e-12 * self.h))[:, None]
        rhs = k1 * (self.inc.T @ d) + k2 * cp
        g = np.column_stack([self.solve(np.ascontiguousarray(rhs[:, j])) for j in range(3)])
        return g, rhs - self.gmat @ x

    if c == 1.0:
        return contextlib.nullcontext()
    return mock.patch.multiple(cls, energy=energy, global_step=global_step)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--presets", default="vault1,saddle", help="comma-separated preset names")
    ap.add_argument("--ratios", type=floats, default=[1.0, 0.3, 0.1],
                    help="stiffness ratios c of a compressed edge, comma-separated (1: the designer's U_A)")
    ap.add_argument("--resolution-mm", type=float, default=20.0)
    args = ap.parse_args(argv)
    if any(not 0.0 <= c <= 1.0 for c in args.ratios):
        ap.error(f"--ratios: every c must lie in [0, 1] (the global matrix majorizes U_A only then), got {args.ratios}")
    print("| preset | compression ratio c | σ min / avg / max | constructible | Ŝ to S RMS mm (max) | strings "
          "| named face | RMS mm (% diag) | max mm | converged |")
    print("|---|---:|---|---|---|---:|---|---|---:|---|")
    for name in args.presets.split(","):
        for c in args.ratios:
            with softer_in_compression(c):
                result = designed_preset(name)
            sig = result.approx.report.sigma
            target = result.approx.target
            near = MeshProjector(target.vertices, target.faces).closest(result.approx.xyz).distance
            print(f"| {name} | {c:g} | {sig['min']:.4f} / {sig['avg']:.4f} / {sig['max']:.4f} "
                  f"| {'yes' if result.approx.report.constructible else 'no'} "
                  f"| {np.sqrt(np.mean(near ** 2)) / MM:.2f} ({near.max() / MM:.2f}) "
                  + open_loop_cells(result, args.resolution_mm * MM), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
