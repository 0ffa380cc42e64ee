"""A preset designed in memory with the paper's calibration values (the objects the benchmarks inflate)."""

from __future__ import annotations


def designed_preset(preset: str, params=None):
    """Design ``preset`` (paper calibration values, seed 0; ``params`` a DesignParams, default the
    defaults); return its DesignResult (SI)."""
    from design.pipeline import DesignParams, design
    from design.presets import preset as load

    target, mattress = load(preset)
    return design(target, mattress, params=DesignParams() if params is None else params, progress=False)
