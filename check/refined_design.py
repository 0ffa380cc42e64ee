"""A refined design: new string lengths, the strings no longer needed dropped, the coverage recomputed.

Used by :func:`airmat.check.refinement.refine` once the refined lengths are known
(real lengths, m). SI units inside; the coverage summary is in mm, as design.json's.
"""

from __future__ import annotations

import dataclasses

__all__ = ["refined_design", "REFINE_FLAG"]

#: flag of a string whose refined length hit the shortest a tie allows
REFINE_FLAG = "refine_at_shortest"


def refined_design(design, l_real, dropped, flagged):
    """The design with new real median lengths (lo95 / hi95 shifted alike), dropped strings removed.

    Its ``open_loop`` keeps the strings as they were before any refinement (a design
    refined again keeps the first open loop): its inflations start from them.

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
    l_real : ndarray of shape (k,)
        New real median length of each string (m).
    dropped, flagged : ndarray of shape (k,) of bool

    Returns
    -------
    airmat.design.pipeline.DesignResult
    """
    new = []
    for s, l, drop, flag in zip(design.pattern.strings, l_real, dropped, flagged):
        if drop:
            continue
        shift = float(l) - s.l_median
        flags = s.flags + ((REFINE_FLAG,) if flag and REFINE_FLAG not in s.flags else ())
        new.append(dataclasses.replace(s, l_median=float(l), l_lo95=s.l_lo95 + shift, l_hi95=s.l_hi95 + shift,
                                       flags=flags))
    n_drop = {fam: sum(1 for s, d in zip(design.pattern.strings, dropped) if d and s.dash.family == fam)
              for fam in ("k1", "k2")}
    n_no = {fam: design.pattern.n_no_string.get(fam, 0) + n_drop[fam] for fam in ("k1", "k2")}
    notes = design.pattern.notes + ((f"refinement dropped {sum(n_drop.values())} strings that reached their "
                                     f"flat span",) if any(dropped) else ())
    coverage = design.pattern.coverage
    if any(dropped):
        coverage, more = _coverage_after(design, tuple(new))
        notes += more
    pattern = dataclasses.replace(design.pattern, strings=tuple(new), n_no_string=n_no, notes=notes,
                                  coverage=coverage)
    open_loop = design.open_loop if design.open_loop is not None else design.pattern.strings
    return dataclasses.replace(design, pattern=pattern, open_loop=open_loop)


def _coverage_after(design, strings):
    """The pattern's coverage (mm, airmat.design.coverage) with only ``strings`` left, and notes.

    It needs the curvature field and the stripes, which a design read from its folder
    does not keep: then the coverage is None (not known) and a note says why.
    """
    if design.mfield is None or design.stripes is None:
        return None, ("the coverage of the refined pattern is not known: the design was read from its folder, "
                      "which keeps no curvature field (design it again with --refine to get it)",)
    from airmat.design.coverage import pattern_coverage
    from airmat.design.tie_grid import snap_dashes

    m, params = design.mattress, design.params
    sp = params.stripe_params(params.L)
    dashes, _ = snap_dashes(design.stripes.dashes, grid=params.tie_grid, width=m.width, height=m.height)
    cover = pattern_coverage(design.mfield, strings, dashes, design.approx.uv, width=m.width, height=m.height,
                             kappa_min=params.kappa_min, L=params.L, mu2=sp.mu2, margin=sp.margin,
                             end_dashes=sp.end_dashes)
    return cover.summary_mm(), tuple(f"after the refinement: {n}" for n in cover.notes())
