"""Experiment: is the over-bending of dense patterns the designer's curvature conversion?

Usage::

    .venv/bin/python bench/bench_free_face.py eq3 vault1,saddle        # the designer as it is
    .venv/bin/python bench/bench_free_face.py free vault1,saddle       # lengths from the free face's model
    .venv/bin/python bench/bench_free_face.py freecal vault1,saddle    # the same, checked with the calibrated map

The designer turns Ŝ's curvature into a string length with Equation 3's κ₁, the
circle of the string face (paper Figure 4b). Ŝ stands for the face opposite the
strings, which the paper's model bends by (π − θ)/L (Figure 4a). ``free`` replaces
the conversion by that relation, l* = (L − (π − θ) d) sin(θ/2) with θ = π − κ L,
and inflates at 20 mm (median lengths); prints the deviation of the named face and
the median ratio of realized to target curvature over dashes with |κ| >= 1 1/m.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import airmat.design.string_lengths as string_lengths  # noqa: E402
from airmat.check.inflation_check import check  # noqa: E402
from airmat.design.pipeline import design  # noqa: E402
from airmat.design.presets import preset  # noqa: E402


def free_face_length(kappa, L, delta, d):
    """Length l (m) whose free face bends by κ in the paper's model: (π − θ) / L = κ."""
    theta = np.pi - np.asarray(kappa, float) * L
    return np.maximum((L - (np.pi - theta) * d) * np.sin(theta / 2) - 2 * delta, 0.0)


def main(argv=None) -> int:
    mode, names = (argv or sys.argv[1:])[:2]
    if mode.startswith("free"):
        string_lengths.string_length = free_face_length
    for name in names.split(","):
        target, mattress = preset(name)
        result = design(target, mattress, progress=False)
        run = check(result, resolution=0.02, envelope=False, calibrated_map=mode.endswith("cal"),
                    workers=1).runs["median"]
        kappa = np.array([s.kappa for s in result.pattern.strings])
        strong = np.abs(kappa) >= 1
        ratio = run.kappa_realized[strong] / kappa[strong]
        print(f"{mode} {name}: RMS {run.deviation.rms * 1e3:.1f} mm ({run.deviation.rms_pct_diag:.2f} %), "
              f"realized/target median {np.median(ratio):.2f}, within 10 %: "
              f"{int(np.sum(np.abs(ratio - 1) < 0.1))} of {int(strong.sum())}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
