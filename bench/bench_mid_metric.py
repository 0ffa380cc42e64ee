"""Experiment: Ŝ as the mid-surface in the metric the strings give, against the default (length-keeping face).

Usage::

    .venv/bin/python bench/bench_mid_metric.py [--presets saddle,vault1] [--refine]

Not a product feature: the default Ŝ keeps Ω's lengths and the check names the
face opposite the strings. Here, after the default relaxation, Ŝ is relaxed
again (twice, each from the last) with every A1 rest length shortened by
d |κₙ| / 2, κₙ the normal curvature of the current Ŝ along the edge (from its
principal curvatures at the edge's two ends): the mid-surface of a mattress
whose string faces shorten by d |κ| while the other face keeps its length.
The strings then come from that Ŝ's curvature and the check (and, with
``--refine``, the refinement) compares the mid-surface. Each row gives the
named-face deviation of the default next to the mid-surface deviation of the
experiment, % of the diagonal, at 20 mm. The relaxation is wrapped by
replacing ``airmat.design.surface.relax_to_target`` for the experiment's designs,
which are made with ``face_metric=False`` (the default named-face metric of
airmat.design.face_metric would otherwise relax them once more) and ``free_face_span=False``
(airmat.design.free_face reads Ŝ as the named face, its free face d away; here Ŝ is the
mid-surface, whose metric already holds the faces' shortening).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import airmat.design.surface as surface_module  # noqa: E402
from airmat.check.inflation_check import check  # noqa: E402
from airmat.check.refinement import refine  # noqa: E402
from designed_preset import designed_preset  # noqa: E402
from airmat.design.pipeline import DesignParams  # noqa: E402
from airmat.design.closest_point import MeshProjector  # noqa: E402
from airmat.design.curvature import principal_curvature  # noqa: E402
from airmat.design.local_global import UAProblem, iterate  # noqa: E402

ROUNDS = 2
_default_relax = surface_module.relax_to_target


def _mid_metric_relax(thickness):
    """The default relaxation followed by ROUNDS relaxations in the mid-surface metric of a mattress this thick."""
    return lambda uv, faces, target, **kw: _relax_mid(uv, faces, target, thickness, **kw)


def _relax_mid(uv, faces, target, thickness, **kw):
    result = _default_relax(uv, faces, target, **kw)
    prob = UAProblem(uv, faces, MeshProjector(target.vertices, target.faces), kw.get("k_a1", 1.0),
                    kw.get("k_a2", 0.2), kw.get("k_a3", 0.02))
    rest, edges, x = prob.rest.copy(), prob.edges, result.xyz
    for _ in range(ROUNDS):
        curv = principal_curvature(x, faces)
        t = x[edges[:, 1]] - x[edges[:, 0]]
        t /= np.linalg.norm(t, axis=1)[:, None]
        kn = np.zeros(len(edges))
        for end in (0, 1):
            v = edges[:, end]
            for i in range(2):
                kn += 0.5 * np.abs(curv.kappa[v, i]) * np.einsum("kd,kd->k", t, curv.directions[v, i]) ** 2
        prob.rest = rest * (1.0 - 0.5 * thickness * kn)
        x = iterate(prob, x.copy(), tol=1e-4, stall=1e-7, max_iter=1000, window=5, bar=None)[0]
    return dataclasses.replace(result, xyz=x)



def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--presets", default="saddle,vault1")
    ap.add_argument("--refine", action="store_true")
    args = ap.parse_args(argv)
    cols = "default: named face open loop | mid metric: mid open loop"
    if args.refine:
        cols += " | default refined | mid metric refined"
    print(f"| preset | {cols} |")
    print("|---|" + "---|" * (4 if args.refine else 2))
    for name in args.presets.split(","):
        base = designed_preset(name)
        surface_module.relax_to_target = _mid_metric_relax(base.mattress.thickness)
        try:
            mid = designed_preset(name, DesignParams(face_metric=False, free_face_span=False))
        finally:
            surface_module.relax_to_target = _default_relax
        cells = [check(base, envelope=False).runs["median"].deviation.rms_pct_diag,
                 check(mid, envelope=False, surface="mid").runs["median"].deviation.rms_pct_diag]
        if args.refine:
            cells += [refine(base).deviation_after.rms_pct_diag, refine(mid, surface="mid").deviation_after.rms_pct_diag]
        print(f"| {name} | " + " | ".join(f"{c:.2f} %" for c in cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
