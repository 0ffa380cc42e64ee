"""A preset designed in memory with the paper's calibration values (the objects the benchmarks inflate)."""

from __future__ import annotations


def designed_preset(preset: str):
    """Design ``preset`` (paper calibration values, seed 0); return its DesignResult (SI)."""
    from design.pipeline import design
    from design.presets import preset as load

    target, mattress = load(preset)
    return design(target, mattress, progress=False)
