"""Coverage of the pattern: unstrung bands found, classified and explained."""

from types import SimpleNamespace

import numpy as np
import pytest

from airmat.synthetic.targets import cylinder
from airmat.design.coverage import pattern_coverage
from airmat.design.mattress import Mattress
from airmat.design.pipeline import DesignParams, design
from tests.design.analytic_fields import cylinder_field, grid_uv

W, H, L, MU2, MARGIN = 0.83, 0.74, 0.3, 0.05, 0.03


def _lines(us, v0=MARGIN, n=2, family="k1", sign=1.0):
    """Strings along v at each u in ``us``: ``n`` dashes of arc L end to end from v0 (all with a string)."""
    out = []
    for u in us:
        for j in range(n):
            poly = np.column_stack([np.full(7, u), np.linspace(v0 + j * L, v0 + (j + 1) * L, 7)])
            out.append(SimpleNamespace(dash=SimpleNamespace(family=family, polyline=poly), kappa=sign))
    return out


def _cov(field, strings, dashes=None, end_dashes=False):
    dashes = [s.dash for s in strings] if dashes is None else dashes
    return pattern_coverage(field, strings, dashes, grid_uv(W, H, 0.01), width=W, height=H, kappa_min=0.25, L=L,
                            mu2=MU2, margin=MARGIN, end_dashes=end_dashes)


@pytest.fixture(scope="module")
def field():
    # k1 along v (angle pi/2): the lines run along v, spaced along u
    return cylinder_field(W, H, kappa=3.0, angle=np.pi / 2)


def test_full_pattern_is_covered_and_its_end_bands_are_explained(field):
    strings = _lines(np.arange(MARGIN, W - MARGIN + 1e-9, MU2))
    c = _cov(field, strings)
    k1 = c.families["k1"]
    assert k1.covered and k1.interior_gap_max == 0.0
    # the lines end at v = 0.63 m: a 0.11 m band up to the edge where no 0.3 m dash fits
    assert k1.edge_band_max == pytest.approx(H - MARGIN - 2 * L, abs=0.011)
    notes = c.notes()
    assert len(notes) == 1 and "no whole dash of L = 300 mm fits" in notes[0] and notes[0].startswith("k1")
    assert c.families["k2"].n_need == 0
    # whole dashes only: the note says what fills the band; with end dashes (the band remains) it does not
    assert "--end-dashes" in notes[0]
    assert "--end-dashes" not in _cov(field, strings, end_dashes=True).notes()[0]


def test_a_missing_line_is_an_interior_gap_and_named(field):
    us = np.arange(MARGIN, W - MARGIN + 1e-9, MU2)
    hole = np.abs(us - 0.43) < 0.08              # three lines left out: a 0.2 m band in the middle
    c = _cov(field, _lines(us[~hole]))
    k1 = c.families["k1"]
    assert not k1.covered
    assert k1.interior_gap_max == pytest.approx(0.5 * (us[~hole][us[~hole] > 0.43].min()
                                                       - us[~hole][us[~hole] < 0.43].max()), abs=0.006)
    assert any("the tracer found no line there" in n for n in c.notes())


def test_dashes_without_strings_are_a_weak_band_not_a_hole(field):
    us = np.arange(MARGIN, W - MARGIN + 1e-9, MU2)
    hole = np.abs(us - 0.43) < 0.08
    strings = _lines(us[~hole])
    dashes = [s.dash for s in strings] + [s.dash for s in _lines(us[hole])]   # traced, but got no string
    c = _cov(field, strings, dashes)
    k1 = c.families["k1"]
    assert k1.interior_gap_max == 0.0 and k1.weak_band_max > k1.limit
    assert k1.weak_kappa == pytest.approx(3.0)
    assert any("mean kappa is below it" in n for n in c.notes())


def test_no_string_at_all_where_needed_is_said(field):
    c = _cov(field, [])
    assert not np.isfinite(c.families["k1"].gap_max) and not c.families["k1"].covered
    assert c.summary_mm()["k1"]["gap_max_mm"] is None
    assert "no string although" in c.notes()[0]


def test_default_design_of_a_cylinder_leaves_no_hole():
    """The default pattern (dashes end to end, lines 50 mm apart) leaves no unstrung band inside the pattern."""
    surf = cylinder(radius=0.25, length=1.2, arc=1.0, spacing=0.02)
    r = design(surf, Mattress(W, H), params=DesignParams(spacing=0.04), progress=False)
    cov = r.pattern.coverage
    assert cov["k1"]["covered"] and cov["k1"]["interior_gap_max_mm"] <= cov["k1"]["limit_mm"]
    assert cov["k1"]["weak_band_max_mm"] <= cov["k1"]["limit_mm"]
    assert cov["k2"]["need_points"] == 0
    # whatever band is left along the edge is explained in the notes
    if cov["k1"]["edge_band_max_mm"] > cov["k1"]["limit_mm"]:
        assert any("no whole dash" in n for n in r.pattern.notes)


def test_the_design_notes_suggest_end_dashes_for_an_edge_band_only_when_they_are_off():
    """vault1's k1 lines end in a 153 mm band without strings; with end dashes it shrinks to 113 mm (still
    over the 80 mm limit) and the note no longer suggests them."""
    from airmat.design.pipeline import DesignParams, design
    from airmat.design.presets import preset

    target, mattress = preset("vault1")
    notes = {ed: [n for n in design(target, mattress, params=DesignParams(end_dashes=ed), progress=False).pattern.notes
                  if "band up to" in n] for ed in (False, True)}
    assert notes[False] and all("--end-dashes" in n for n in notes[False])
    assert notes[True] and not any("--end-dashes" in n for n in notes[True])
