"""Re-tie list between two designs: kept by nodes, re-tied one to one by least movement, the rest removed/added."""

from types import SimpleNamespace

import numpy as np
import pytest

from airmat.errors import InputError
from airmat.design.mattress import Mattress
from airmat.design.pattern import Dash, Pattern, TensionString
from airmat.design.retie import retie_plan

G = 0.02


def _s(sid, side, a, b, l=0.2):
    """A string between grid nodes a, b = (row, col)."""
    pts = np.array([[a[1] * G, a[0] * G], [b[1] * G, b[0] * G]])
    dash = Dash(sid, "k1", 1, 1, pts, float(np.linalg.norm(pts[1] - pts[0])), a_node=a, b_node=b)
    return TensionString(dash=dash, kappa=1.0 if side == "bottom" else -1.0, side=side, l_median=l, l_lo95=l,
                         l_hi95=l)


def _design(strings, mattress=Mattress(0.83, 0.74)):
    return SimpleNamespace(approx=SimpleNamespace(mattress=mattress),
                           pattern=Pattern(strings=tuple(strings), L=0.3, n_dashes={}, n_no_string={}))


def test_same_nodes_stay_others_are_retied_by_least_movement():
    a = _design([_s("k1-001-01", "bottom", (2, 3), (2, 18), 0.20),
                 _s("k1-002-01", "bottom", (10, 3), (10, 18)),
                 _s("k1-003-01", "bottom", (20, 3), (20, 18)),
                 _s("k2-001-01", "top", (5, 5), (20, 5))])
    b = _design([_s("k1-001-01", "bottom", (2, 18), (2, 3), 0.18),      # same nodes, reversed, new length
                 _s("k1-002-01", "bottom", (21, 3), (21, 18)),           # nearest to A's k1-003-01
                 _s("k1-003-01", "bottom", (11, 4), (11, 19)),           # nearest to A's k1-002-01
                 _s("k2-001-01", "top", (5, 6), (20, 6)),
                 _s("k2-002-01", "top", (5, 30), (20, 30))])
    plan = retie_plan(a, b)
    assert plan.counts == {"keep": 1, "retie": 3, "remove": 0, "add": 1}
    keep = [s for s in plan.steps if s.action == "keep"][0]
    assert keep.a.dash.id == "k1-001-01" and keep.b.l_median == 0.18 and keep.move == 0.0
    pairs = {(s.a.dash.id, s.b.dash.id) for s in plan.steps if s.action == "retie"}
    assert pairs == {("k1-002-01", "k1-003-01"), ("k1-003-01", "k1-002-01"), ("k2-001-01", "k2-001-01")}
    move = {s.a.dash.id: s.move for s in plan.steps if s.action == "retie"}
    assert move["k1-003-01"] == pytest.approx(2 * G) and move["k1-002-01"] == pytest.approx(2 * np.sqrt(2) * G)
    assert [s.action for s in plan.steps] == ["keep", "retie", "retie", "retie", "add"]


def test_faces_are_not_mixed_and_leftovers_are_removed():
    a = _design([_s("k1-001-01", "top", (2, 3), (2, 18)), _s("k1-002-01", "top", (4, 3), (4, 18))])
    b = _design([_s("k1-001-01", "bottom", (2, 3), (2, 18))])
    plan = retie_plan(a, b)
    assert plan.counts == {"keep": 0, "retie": 0, "remove": 2, "add": 1}


def test_other_mattress_or_free_ends_are_refused():
    a = _design([_s("k1-001-01", "top", (2, 3), (2, 18))])
    with pytest.raises(InputError, match="different mattresses"):
        retie_plan(a, _design([], Mattress(2.6, 1.6)))
    s = _s("k1-001-01", "top", (2, 3), (2, 18))
    free = TensionString(dash=Dash("k1-001-01", "k1", 1, 1, s.dash.polyline, s.dash.length), kappa=-1.0,
                         side="top", l_median=0.2, l_lo95=0.2, l_hi95=0.2)
    with pytest.raises(InputError, match="tie-grid-mm"):
        retie_plan(a, _design([free]))
