"""The paper's values (airmat.constants) and the places that must agree with them."""

import pytest

from airmat.constants import (LARGE_MATTRESS, PAPER_D, PAPER_D_SD, PAPER_DELTA, PAPER_DELTA_SD, PAPER_L,
                              SMALL_MATTRESS)


def test_paper_values():
    assert (PAPER_L, PAPER_DELTA, PAPER_D) == (0.300, 0.018, 0.070)
    assert (PAPER_DELTA_SD, PAPER_D_SD) == (0.003, 0.005)
    assert SMALL_MATTRESS == (0.83, 0.74) and LARGE_MATTRESS == (2.60, 1.60)


def test_users_take_the_shared_values():
    from airmat.calib.model import kappa_max
    from airmat.design.calibration_source import PAPER
    from airmat.design.constructibility import PAPER_KAPPA_MAX
    from airmat.design.mattress import Mattress
    from airmat.design.presets import LARGE, SMALL
    from airmat.design.stripes import StripeParams

    assert PAPER == {"L": PAPER_L, "delta": PAPER_DELTA, "d": PAPER_D, "delta_sd": PAPER_DELTA_SD,
                     "d_sd": PAPER_D_SD}
    assert PAPER_KAPPA_MAX == pytest.approx(float(kappa_max(PAPER_L, PAPER_DELTA, PAPER_D)))
    assert Mattress(1.0, 1.0).thickness == PAPER_D and StripeParams().L == PAPER_L
    assert (SMALL.width, SMALL.height) == SMALL_MATTRESS and (LARGE.width, LARGE.height) == LARGE_MATTRESS
