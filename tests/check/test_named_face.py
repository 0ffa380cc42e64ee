"""The check's named face: the face whose metric Ŝ was relaxed in, else the one opposite the strings."""

from types import SimpleNamespace

import numpy as np
import pytest

from airmat.check.inflation_check import named_face


def _design(metric_face, kappas):
    report = None if metric_face is None else SimpleNamespace(metric={"face": metric_face, "min_ratio": 0.9})
    strings = tuple(SimpleNamespace(kappa=k) for k in kappas)
    return SimpleNamespace(approx=SimpleNamespace(report=report), pattern=SimpleNamespace(strings=strings))


def _strings(top):
    n = len(top)
    return SimpleNamespace(a=np.zeros((n, 2)), b=np.tile([0.3, 0.0], (n, 1)), top=np.asarray(top, bool))


@pytest.mark.parametrize("metric,expected", [(None, "top"), ("flat", "top"), ("top", "top"), ("bottom", "bottom")])
def test_the_design_metric_names_the_face(metric, expected):
    # two bottom strings bend more than one top string: opposite them is the top face, unless the
    # design's Ŝ was relaxed in another face's metric, which then wins
    d = _design(metric, [3.0, 3.0, -1.0])
    assert named_face(d, _strings([False, False, True])) == expected


def test_without_a_metric_the_face_opposite_the_larger_share():
    assert named_face(_design("flat", [1.0, -3.0, -3.0]), _strings([False, True, True])) == "bottom"
