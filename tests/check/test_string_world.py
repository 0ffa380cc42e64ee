"""airmat.check.string_world: the chain from a world (Δ, d, cut error, scatter) to rest lengths."""

from dataclasses import replace
from pathlib import Path
import sys

import numpy as np
import pytest

from airmat.calib.model import kappa1
from airmat.check.inflation_check import design_strings
from airmat.check.string_world import world_strings
from airmat.design.design_io import read_design

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "cli"))
from test_inflate_cli import make_design  # noqa: E402


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    return read_design(make_design(tmp_path_factory.mktemp("world") / "design"))


def _median(design):
    cal = design.calibration
    return cal.delta_median, float(np.median(cal.d))


def test_the_median_world_gives_the_median_rest_lengths(small):
    w = world_strings(small, *_median(small))
    assert np.allclose(w.rest, design_strings(small).rest, rtol=0, atol=1e-12)
    assert w.rest.shape == (2,)


def test_a_cut_error_in_the_median_world_is_that_much_longer(small):
    """On the median mattress the chain inverts Equation 3 exactly: a string cut e longer is e longer."""
    e = np.array([0.003, -0.002])
    w = world_strings(small, *_median(small), cut_error=e)
    assert np.allclose(w.length - [s.l_median for s in small.pattern.strings], e, atol=1e-9)


def test_a_world_with_another_delta_bends_by_its_equation3(small):
    delta, d = _median(small)
    w = world_strings(small, np.array([delta, delta + 0.004]), np.array([d, d]))
    assert w.kappa.shape == (2, 2)
    l = np.array([s.l_median for s in small.pattern.strings])
    span = np.array([s.eq3_span for s in small.pattern.strings])
    assert np.allclose(w.kappa[1], kappa1(l, span, delta + 0.004, d))
    # a larger end slip bends less (Equation 3), which the median mattress does with a longer string
    assert np.all(w.kappa[1] < w.kappa[0]) and np.all(w.length[1] > w.length[0])
