"""airmat.json_doc: versions first, no bare NaN (null with its reason)."""

import json
import math

import numpy as np
import pytest

from airmat import __version__
from airmat.json_doc import SCHEMA_VERSION, dumps, finish


def test_versions_come_first_and_replace_stale_ones():
    doc = finish({"name": "x", "airmat_version": "0.0.0", "schema_version": 0})
    assert list(doc)[:2] == ["schema_version", "airmat_version"]
    assert doc["schema_version"] == SCHEMA_VERSION and doc["airmat_version"] == __version__
    assert "null_reasons" not in doc                          # nothing was missing


def test_nan_becomes_null_with_a_reason_at_its_pointer():
    doc = finish({"a": {"radius_mm": float("inf"), "ok": 1.5},
                  "c": [1.0, np.float64("nan")], "k/x": np.nan}, reasons={"radius_mm": "flat"})
    assert doc["a"] == {"radius_mm": None, "ok": 1.5} and doc["c"] == [1.0, None] and doc["k/x"] is None
    assert doc["null_reasons"] == {"/a/radius_mm": "flat", "/c/1": "not a finite number (nan)",
                                   "/k~1x": "not a finite number (nan)"}


def test_finish_is_idempotent_and_keeps_earlier_reasons():
    once = finish({"v": math.nan}, reasons={"v": "why"})
    assert finish(once) == once


def test_numpy_values_become_plain_json():
    doc = finish({"i": np.int64(3), "b": np.bool_(True), "a": np.array([[1.0, np.nan]])})
    assert doc["i"] == 3 and type(doc["i"]) is int and doc["b"] is True and doc["a"] == [[1.0, None]]
    assert "NaN" not in dumps({"a": np.array([np.nan])})
    assert json.loads(dumps({"a": np.array([np.nan])}))["null_reasons"] == {"/a/0": "not a finite number (nan)"}


def test_dumps_refuses_what_finish_cannot_make_json():
    with pytest.raises(TypeError):
        dumps({"x": object()})
