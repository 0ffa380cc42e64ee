"""Re-tie list between two designs: keep / re-cut by nodes and length, move one to one by least movement,
the rest removed or added; every case hand-computed on a 20 mm grid."""

from types import SimpleNamespace

import numpy as np
import pytest

from airmat.errors import InputError
from airmat.design.mattress import Mattress
from airmat.design.pattern import Dash, Pattern, TensionString
from airmat.design.retie import ACTIONS, CUT_TOLERANCE, retie_plan

G = 0.02   # grid pitch (m)


def _s(sid, side, a, b, l=0.2):
    """A string between grid nodes a, b = (row, col), of length l (m)."""
    pts = np.array([[a[1] * G, a[0] * G], [b[1] * G, b[0] * G]])
    dash = Dash(sid, "k1", 1, 1, pts, float(np.linalg.norm(pts[1] - pts[0])), a_node=a, b_node=b)
    return TensionString(dash=dash, kappa=1.0 if side == "bottom" else -1.0, side=side, l_median=l, l_lo95=l,
                         l_hi95=l)


def _design(strings, mattress=Mattress(0.83, 0.74)):
    return SimpleNamespace(approx=SimpleNamespace(mattress=mattress),
                           pattern=Pattern(strings=tuple(strings), L=0.3, n_dashes={}, n_no_string={}))


def _by_a(plan):
    return {s.a.dash.id: s for s in plan.steps if s.a is not None}


def test_the_five_categories_on_hand_computed_designs():
    a = _design([_s("s-keep", "bottom", (2, 3), (2, 18), 0.2000),
                 _s("s-recut", "bottom", (6, 3), (6, 18), 0.2000),
                 _s("s-move", "bottom", (10, 3), (10, 18), 0.2000),
                 _s("s-remove", "top", (5, 5), (20, 5), 0.1500)])
    b = _design([_s("t-keep", "bottom", (2, 18), (2, 3), 0.2000),     # same nodes (reversed), same length
                 _s("t-recut", "bottom", (6, 3), (6, 18), 0.2050),    # same nodes, +5 mm
                 _s("t-move", "bottom", (11, 3), (11, 18), 0.2100),   # one row up: each end moves 20 mm
                 _s("t-add", "bottom", (30, 3), (30, 18), 0.1900)])
    plan = retie_plan(a, b)
    assert plan.counts == {"keep": 1, "recut": 1, "move": 1, "remove": 1, "add": 1}
    assert [s.action for s in plan.steps] == list(ACTIONS)               # workshop order
    steps = _by_a(plan)
    assert steps["s-keep"].action == "keep" and steps["s-keep"].b.dash.id == "t-keep"
    assert steps["s-keep"].dl == 0.0 and steps["s-keep"].move == 0.0
    recut = steps["s-recut"]
    assert recut.action == "recut" and recut.b.dash.id == "t-recut" and recut.move == 0.0
    assert recut.dl * 1e3 == pytest.approx(5.00, abs=1e-9)
    move = steps["s-move"]
    assert move.action == "move" and move.b.dash.id == "t-move"
    assert move.move == pytest.approx(2 * G) and move.dl * 1e3 == pytest.approx(10.0, abs=1e-9)
    assert steps["s-remove"].action == "remove" and steps["s-remove"].b is None
    add = [s for s in plan.steps if s.action == "add"][0]
    assert add.a is None and add.b.dash.id == "t-add" and np.isnan(add.dl) and np.isnan(add.move)


@pytest.mark.parametrize("dl_mm,tol_mm,action", [
    (0.0, 0.0, "keep"), (0.5, 1.0, "keep"), (-1.0, 1.0, "keep"),      # exactly the tolerance: kept
    (1.01, 1.0, "recut"), (-29.7, 1.0, "recut"), (29.7, 30.0, "keep"), (0.01, 0.0, "recut")])
def test_the_cut_tolerance_splits_keep_from_recut(dl_mm, tol_mm, action):
    a = _design([_s("s", "top", (2, 3), (2, 18), 0.2)])
    b = _design([_s("s", "top", (2, 3), (2, 18), 0.2 + dl_mm * 1e-3)])
    plan = retie_plan(a, b, cut_tolerance=tol_mm * 1e-3)
    assert [s.action for s in plan.steps] == [action]
    assert plan.cut_tolerance == tol_mm * 1e-3


def test_default_tolerance_is_one_millimetre_and_stated_in_the_repr():
    assert CUT_TOLERANCE == 1e-3
    a = _design([_s("s", "top", (2, 3), (2, 18), 0.2)])
    plan = retie_plan(a, a)
    assert repr(plan) == "<RetiePlan: keep 1, re-cut 0, move 0, remove 0, add 0 (cut tolerance 1 mm)>"


def test_moves_pair_strings_one_to_one_by_least_movement():
    a = _design([_s("k1-001-01", "bottom", (2, 3), (2, 18), 0.20),
                 _s("k1-002-01", "bottom", (10, 3), (10, 18)),
                 _s("k1-003-01", "bottom", (20, 3), (20, 18)),
                 _s("k2-001-01", "top", (5, 5), (20, 5))])
    b = _design([_s("k1-001-01", "bottom", (2, 18), (2, 3), 0.18),      # same nodes, reversed, -20 mm
                 _s("k1-002-01", "bottom", (21, 3), (21, 18)),           # nearest to A's k1-003-01
                 _s("k1-003-01", "bottom", (11, 4), (11, 19)),           # nearest to A's k1-002-01
                 _s("k2-001-01", "top", (5, 6), (20, 6)),
                 _s("k2-002-01", "top", (5, 30), (20, 30))])
    plan = retie_plan(a, b)
    assert plan.counts == {"keep": 0, "recut": 1, "move": 3, "remove": 0, "add": 1}
    recut = [s for s in plan.steps if s.action == "recut"][0]
    assert recut.a.dash.id == "k1-001-01" and recut.dl * 1e3 == pytest.approx(-20.0)
    pairs = {(s.a.dash.id, s.b.dash.id) for s in plan.steps if s.action == "move"}
    assert pairs == {("k1-002-01", "k1-003-01"), ("k1-003-01", "k1-002-01"), ("k2-001-01", "k2-001-01")}
    move = {s.a.dash.id: s.move for s in plan.steps if s.action == "move"}
    assert move["k1-003-01"] == pytest.approx(2 * G) and move["k1-002-01"] == pytest.approx(2 * np.sqrt(2) * G)
    assert [s.action for s in plan.steps] == ["recut", "move", "move", "move", "add"]


def test_faces_are_not_mixed_and_leftovers_are_removed():
    a = _design([_s("k1-001-01", "top", (2, 3), (2, 18)), _s("k1-002-01", "top", (4, 3), (4, 18))])
    b = _design([_s("k1-001-01", "bottom", (2, 3), (2, 18))])
    plan = retie_plan(a, b)
    assert plan.counts == {"keep": 0, "recut": 0, "move": 0, "remove": 2, "add": 1}


def test_other_mattress_free_ends_or_a_bad_tolerance_are_refused():
    a = _design([_s("k1-001-01", "top", (2, 3), (2, 18))])
    with pytest.raises(InputError, match="different mattresses"):
        retie_plan(a, _design([], Mattress(2.6, 1.6)))
    s = _s("k1-001-01", "top", (2, 3), (2, 18))
    free = TensionString(dash=Dash("k1-001-01", "k1", 1, 1, s.dash.polyline, s.dash.length), kappa=-1.0,
                         side="top", l_median=0.2, l_lo95=0.2, l_hi95=0.2)
    with pytest.raises(InputError, match="tie-grid-mm"):
        retie_plan(a, _design([free]))
    for bad in (-1e-3, float("nan"), float("inf")):
        with pytest.raises(InputError, match="cut tolerance"):
            retie_plan(a, a, cut_tolerance=bad)
