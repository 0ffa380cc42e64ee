"""Small objects for the report tests: a calibration (12 scans), the vault1 design (40 mm), its check (60 mm)."""

import dataclasses

import pytest

from airmat.units import MM


@pytest.fixture(scope="session")
def run_objects(tmp_path_factory):
    """(Calibration, DesignResult, DesignCheck) of one small seeded run, as the demo makes them."""
    from airmat.calib.calibrate import calibrate
    from airmat.check.inflation_check import check
    from airmat.synthetic.calibration_set import calibration_set
    from airmat.design.calibration_source import from_calibration
    from airmat.design.pipeline import DesignParams, design
    from airmat.design.presets import preset

    cs = calibration_set(tmp_path_factory.mktemp("synth"), n_points=20000, seed=0)
    cal = calibrate(cs.manifest, seed=0)
    target, mattress = preset("vault1")
    result = design(target, mattress, calibration=from_calibration(cal, source="synthetic"),
                    params=DesignParams(spacing=40 * MM), seed=0)
    return cal, result, check(result, resolution=60 * MM)


@pytest.fixture(scope="session")
def uncalibrated_design(run_objects):
    """The same design with the paper's (uncalibrated) values."""
    from airmat.design.calibration_source import default_calibration

    _, result, _ = run_objects
    return dataclasses.replace(result, calibration=default_calibration(seed=0))
