"""Snapping dash ends to the mattress's grid: nodes, shared ends, the edge, L on the moved polyline."""

import numpy as np
import pytest

from airmat.errors import InputError
from airmat.design.pattern import Dash
from airmat.design.tie_grid import grid_node, snap_dashes

W, H, G = 0.83, 0.74, 0.02


def _dash(i, pts):
    pts = np.asarray(pts, float)
    return Dash(f"k1-001-{i:02d}", "k1", 1, i, pts, float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum()))


def _arc(p):
    return np.linalg.norm(np.diff(p, axis=0), axis=1).sum()


def test_ends_move_to_nodes_and_L_is_the_new_arc_length():
    rng = np.random.default_rng(3)
    dashes = []
    for i in range(1, 8):
        t = np.linspace(0, 1, 5 + i)[:, None]
        a, b = rng.uniform([0.05, 0.05], [0.4, 0.7]), rng.uniform([0.45, 0.05], [0.8, 0.7])
        dashes.append(_dash(i, a + t * (b - a) + 0.02 * np.sin(np.pi * t) * [0, 1]))
    out, rep = snap_dashes(dashes, grid=G, width=W, height=H)
    for d0, d in zip(dashes, out):
        for end, node in ((d.a, d.a_node), (d.b, d.b_node)):
            np.testing.assert_allclose(end, [node[1] * G, node[0] * G], atol=1e-15)
        assert d.length == pytest.approx(_arc(d.polyline), rel=1e-12)
        assert len(d.polyline) == len(d0.polyline)
        # the nearest node: no node is closer to the old end
        for old, new in ((d0.a, d.a), (d0.b, d.b)):
            assert np.linalg.norm(new - old) <= G / np.sqrt(2) + 1e-15
    np.testing.assert_allclose(rep.length_change, [d.length - d0.length for d0, d in zip(dashes, out)])
    assert rep.end_shift.shape == (7, 2) and np.all(rep.end_shift <= G / np.sqrt(2) + 1e-15)
    summary = rep.summary_mm()
    assert summary["grid_mm"] == 20.0 and 0 < summary["end_shift_mm"]["max"] <= 14.15


def test_consecutive_dashes_share_their_node():
    line = np.column_stack([np.linspace(0.111, 0.705, 21), np.full(21, 0.333)])
    d1, d2 = _dash(1, line[:11]), _dash(2, line[10:])
    (s1, s2), _ = snap_dashes([d1, d2], grid=G, width=W, height=H)
    assert s1.b_node == s2.a_node == (17, 20)
    np.testing.assert_array_equal(s1.b, s2.a)


def test_nodes_stay_on_the_mattress():
    nodes = grid_node(np.array([[-0.004, 0.0], [0.8299, 0.7399], [W, H]]), G, W, H)
    # 830 mm / 20 mm = 41.5: the last column inside is 41 (820 mm), the last row 37 (740 mm)
    assert nodes.tolist() == [[0, 0], [37, 41], [37, 41]]


def test_zero_grid_leaves_dashes_free_and_negative_is_refused():
    d = _dash(1, [[0.101, 0.2], [0.4, 0.2]])
    (same,), rep = snap_dashes([d], grid=0.0, width=W, height=H)
    assert same is d and same.a_node is None and rep.grid == 0.0
    with pytest.raises(InputError, match="tie-grid"):
        snap_dashes([d], grid=-0.02, width=W, height=H)
