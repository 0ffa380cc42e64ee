"""A preset designed through the CLI (``airmat design --preset``), read back as a design folder."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path


def designed_preset(preset: str, folder: Path):
    """Design ``preset`` (paper calibration values) into ``folder``; return its DesignFolder."""
    from airmat.cli import main
    from check.design_folder import read_design_folder

    with contextlib.redirect_stdout(io.StringIO()):
        if main(["design", "--preset", preset, "--out", str(folder), "-q"]) != 0:
            raise SystemExit(f"design of the {preset} preset failed")
    return read_design_folder(folder)
