"""What `airmat design --refine` and `airmat refine` share: the refinement options' checks, refine's
keyword arguments, and the lines on stdout about a refinement and the design folder it writes."""

from __future__ import annotations

from airmat.errors import InputError

__all__ = ["check_corrections", "check_regularization", "check_rounds", "refine_options", "refine_lines",
           "refine_not_converged", "wrote_line"]


def check_corrections(option: str, n: int, single_level: bool, single_option: str) -> None:
    """Refuse a negative number of defect corrections, or corrections without a coarse mesh."""
    if n < 0:
        raise InputError(f"{option} must be >= 0, got {n}")
    if n and single_level:
        raise InputError(f"{option} corrects the coarse mesh of the two-level scheme; {single_option} has none")


def check_regularization(option: str, alpha: float | None) -> None:
    """Refuse a regularization weight that is not a finite positive number (None: refine's default)."""
    if alpha is not None and not (0.0 < alpha < float("inf")):
        raise InputError(f"{option} must be a positive number, got {alpha!r}")


def check_rounds(option: str, n: int | None) -> None:
    """Refuse a negative number of re-parametrization rounds (None: refine's default)."""
    if n is not None and n < 0:
        raise InputError(f"{option} must be >= 0, got {n}")


def refine_lines(b: dict) -> list[str]:
    """The lines on stdout for a refine block of design.json (mm, %): deviation before / after, Ŝ's round."""
    lines = [f"  refined in {b['iterations']} iterations, {b['seconds']:.1f} s: named face RMS "
             f"{b['deviation_before']['rms_mm']:.1f} -> {b['deviation_after']['rms_mm']:.1f} mm "
             f"({b['deviation_before']['rms_pct_diag']:.2f} -> {b['deviation_after']['rms_pct_diag']:.2f} % of the "
             f"diagonal); dropped {len(b['dropped'])}, flagged {len(b['flagged'])}"
             + (f"; {b['defect_corrections']} defect correction(s)" if b["defect_corrections"] else "")]
    r = b["reparametrization"]
    if r is not None:
        lines.append(f"  surface points moved {r['moved_rms_mm']:.1f} mm RMS along it (at most {r['moved_max_mm']:.1f} "
                     f"mm; {r['off_surface_rms_mm']:.2f} mm RMS off it) to where the refined mattress puts them; the "
                     f"{b.get('lengths_before', 'open-loop')} lengths are {r['deviation_before']['rms_pct_diag']:.2f} "
                     f"% of the diagonal from it")
    return lines


def refine_options(corrections: int, alpha: float | None, single_level: bool, reparametrize: int | None = None) -> dict:
    """The keyword arguments of :func:`airmat.check.refinement.refine` that the command-line options set."""
    kw = {"corrections": corrections}
    if alpha is not None:
        kw["alpha"] = alpha
    if reparametrize is not None:
        kw["reparametrize"] = reparametrize
    if single_level:
        kw["coarsest"] = 0.0
    return kw


def refine_not_converged(refinement) -> list[str]:
    """What did not converge in a refinement, if one ran (its best lengths are written, never worse than open loop)."""
    return [] if refinement is None or refinement.converged else [f"refinement: {refinement.message}"]


def wrote_line(out) -> str:
    """The line naming the files of a published design folder (design.json first)."""
    from airmat.listing import listed
    from airmat.design.design_io import OUTPUT_FILES

    return f"  wrote {listed(out, OUTPUT_FILES)} to {out}"
