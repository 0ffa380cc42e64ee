"""airmat.inflation.model: with_strings is build_model with only the external strings rebuilt."""

import dataclasses

import numpy as np
import pytest

from airmat.inflation.mesh import build_mattress_mesh
from airmat.inflation.model import Parameters, build_model, with_strings
from airmat.inflation.strings import StringSet


def _strings(rest):
    a = np.array([[0.10, 0.10], [0.10, 0.25]])
    b = np.array([[0.50, 0.12], [0.45, 0.25]])
    return StringSet(a, b, np.array([True, False]), np.asarray(rest, float), ("s1", "s2"))


def test_with_strings_is_build_model_at_the_new_lengths():
    mesh = build_mattress_mesh(0.6, 0.35, 0.07, resolution=0.05)
    params = Parameters(pressure=1500.0)
    base = build_model(mesh, _strings([0.35, 0.30]), params)
    new = _strings([0.28, 0.33])
    got, want = with_strings(base, mesh, new, params), build_model(mesh, new, params)
    assert len(got.springs) == len(want.springs)
    for g, w in zip(got.springs, want.springs):
        for f in dataclasses.fields(g):
            np.testing.assert_array_equal(np.asarray(getattr(g, f.name)), np.asarray(getattr(w, f.name)))
    assert (got.smoothing != want.smoothing).nnz == 0
    # the stiffness EA / l* follows the new rest lengths
    assert not np.array_equal(got.springs[-1].stiffness, base.springs[-1].stiffness)


def test_with_strings_refuses_a_model_without_strings():
    mesh = build_mattress_mesh(0.6, 0.35, 0.07, resolution=0.05)
    with pytest.raises(ValueError, match="no external strings"):
        with_strings(build_model(mesh, None), mesh, _strings([0.3, 0.3]))
