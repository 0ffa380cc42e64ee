"""A preset, or a zoo target, designed in memory with the paper's calibration values (the objects the benchmarks inflate)."""

from __future__ import annotations


def designed_preset(preset: str, params=None, *, refine_at: float | None = None):
    """Design ``preset`` (a preset's name or a zoo target's; paper calibration values, seed 0; ``params`` a DesignParams, default the
    defaults); return its DesignResult (SI). ``refine_at``: a resolution (m) at which the lengths are
    then refined through the inflation (airmat.check.refinement.refine, defaults), the refined design returned."""
    from airmat.design.pipeline import DesignParams, design
    from airmat.design.presets import preset as load

    from airmat.design.presets import PRESETS

    if preset in PRESETS:
        target, mattress = load(preset)
    else:                                   # a zoo target (airmat.synthetic.zoo), by name
        from airmat.design.mattress import Mattress
        from airmat.synthetic.zoo import by_name

        target = by_name(preset)
        mattress = Mattress(*target.mattress)
    result = design(target, mattress, params=DesignParams() if params is None else params, progress=False)
    if refine_at is None:
        return result
    from airmat.check.refinement import refine

    return refine(result, resolution=refine_at).design
