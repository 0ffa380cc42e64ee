"""End to end: a designed preset inflates close to its Ŝ (the designer's output, then U_B), in memory."""

import numpy as np
import pytest

from airmat.check.inflation_check import check
from airmat.design.pipeline import design
from airmat.design.presets import preset


@pytest.mark.slow
def test_vault1_inflates_within_3_percent_of_its_diagonal():
    target, mattress = preset("vault1")
    result = design(target, mattress, progress=False)
    run = check(result, resolution=0.05, envelope=False).runs["median"]
    assert run.inflation.converged
    # 3 % is an acceptance line, not a measurement: measured 1.2 % (12 mm RMS on the 830 x 740 mm
    # mattress) at 50 mm
    assert run.deviation.rms_pct_diag < 3.0
    # the strongly bent dashes (|kappa| > 1 /m) bend the right way, by the right order of magnitude
    kappa = np.array([s.kappa for s in result.pattern.strings])
    strong = np.abs(kappa) > 1.0
    assert strong.sum() >= 4
    ratio = run.kappa_realized[strong] / kappa[strong]
    assert np.all(ratio > 0.5) and np.all(ratio < 2.0)
