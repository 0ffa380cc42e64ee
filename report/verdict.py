"""The verdict card at the top of ``report.html``: does the design land on Ŝ, how sure is it, what to run next.

:func:`check_verdict` reads a :class:`~airmat.check.inflation_check.DesignCheck`: whether the
inflated named face lands within :data:`WITHIN_PCT_DIAG` % of Ŝ's bounding-box diagonal (RMS;
the line the project sets for a constructible design, ``docs/benchmarks.md``), how far it and Ŝ
are from the user's target S (when the design keeps S), the design's constructibility, the
tolerance (the Monte-Carlo band when there is one, else the lo95 / hi95 runs) and the next
command: ``airmat refine`` for open-loop lengths, ``airmat check --samples`` for a band, else
the workshop files. :func:`design_verdict` does the same for a design alone
(``airmat design``, ``airmat refine``: the refinement's promise, or none yet), and
:func:`calibration_verdict` for a calibration alone. :func:`verdict_html` draws the card.
"""

from __future__ import annotations

from dataclasses import dataclass
from html import escape

from airmat.units import M_TO_MM

__all__ = ["WITHIN_PCT_DIAG", "MC_SAMPLES", "Verdict", "check_verdict", "design_verdict", "calibration_verdict",
           "verdict_html"]

#: the line a design must land within: RMS deviation of the named face, % of Ŝ's bounding-box diagonal
WITHIN_PCT_DIAG = 1.0
#: the Monte-Carlo samples the card suggests for a band (a 95th percentile within a few standard errors)
MC_SAMPLES = 64
#: the workshop files of a design folder (airmat.design.design_io)
WORKSHOP_FILES = ("cutting_list.csv", "pattern.dxf", "pattern.svg", "design.3dm")


@dataclass(frozen=True)
class Verdict:
    """What the card says.

    Attributes
    ----------
    kind : {"ok", "warn", "bad"}
        Green: lands within the line, constructible, converged; red: not constructible or not converged.
    headline : str
    facts : tuple of str
        Constructibility, the tolerance, the calibration.
    next_command : str
        The command to run next (empty when there is none).
    next_why : str
        What it gives.
    """

    kind: str
    headline: str
    facts: tuple
    next_command: str
    next_why: str


def _folder(design) -> str:
    return str(design.source) if getattr(design, "source", None) else "DESIGN_DIR"


def _constructible(design) -> tuple:
    """(constructible or None when unknown, the sentence)."""
    rep = design.approx.report
    if rep is None:
        return None, "Constructibility: not assessed."
    if rep.constructible:
        lo, hi = rep.sigma_band
        folds = "" if not rep.folds or not rep.folds["vertices"] else (
            f"; drape-like folds on {100 * rep.folds['share']:.1f} % of Ω, where the mattress gathers by itself")
        return True, (f"Constructible: yes (σ within [{lo:g}, {hi:g}], |κ| ≤ {rep.kappa_max:.2f} 1/m{folds}).")
    return False, "Constructible: NO (" + "; ".join(rep.reasons) + ")."


def _tolerance(check) -> str:
    face, mc = check.surface, check.monte_carlo
    if mc is not None:
        st = mc.stats()
        diag = check.runs["median"].deviation
        scale = diag.rms_pct_diag / diag.rms if diag.rms > 0 else 0.0
        return (f"Tolerance (Monte-Carlo, {mc.draws.n} sampled cuts of the strings): the {face} face's RMS has "
                f"median {st['rms_median'] * M_TO_MM:.1f} mm; 95 % of the built shapes within "
                f"{st['rms_p95'] * M_TO_MM:.1f} mm RMS ({st['rms_p95'] * scale:.2f} % of the diagonal).")
    env = {k: r.deviation for k, r in check.runs.items() if k != "median"}
    if not env:
        return "Tolerance: not computed (no lo95 / hi95 runs, no Monte-Carlo)."
    return (f"Tolerance (every string cut at an end of its 95 % length interval): the {face} face's RMS is "
            + ", ".join(f"{d.rms * M_TO_MM:.1f} mm ({d.rms_pct_diag:.2f} %) at {k}" for k, d in env.items()) + ".")


def _to_target(check) -> list:
    """The fact of the distance to S (mm, as inflate.json's ``to_target``), or none when the design does not keep S."""
    to_s, own = check.runs["median"].to_target, getattr(check, "approx_to_target", None)
    if to_s is None:
        return []
    fact = (f"The inflated {check.surface} face is {to_s.rms * M_TO_MM:.1f} mm RMS from your target S "
            f"({to_s.rms_pct_diag:.2f} % of the diagonal)")
    if own is not None:
        fact += f"; Ŝ itself is {own.rms * M_TO_MM:.1f} mm from S ({own.rms_pct_diag:.2f} %)"
    if to_s.over is not None and to_s.over.any() and to_s.over_share < 1.0:
        fact += (f". Over S, {100 * to_s.over_share:.0f} % of the face (the rest lies beyond S's rim, where S says "
                 f"nothing), it is {to_s.over_rms * M_TO_MM:.1f} mm RMS from S "
                 f"({100 * to_s.over_rms / to_s.diagonal:.2f} %)")
    return [fact + "."]


def check_verdict(check) -> Verdict:
    """The verdict of an inflation check (see the module's docstring).

    Parameters
    ----------
    check : airmat.check.inflation_check.DesignCheck

    Returns
    -------
    Verdict
    """
    d, dev, face = check.design, check.runs["median"].deviation, check.surface
    within = dev.rms_pct_diag <= WITHIN_PCT_DIAG
    ok, constructible = _constructible(d)
    refined = d.refine is not None or check.open_loop is not None
    headline = (f"Lands within {WITHIN_PCT_DIAG:g} % of the diagonal: {'yes' if within else 'no'}. The inflated "
                f"{face} face is {dev.rms * M_TO_MM:.1f} mm RMS from Ŝ ({dev.rms_pct_diag:.2f} % of Ŝ's diagonal; "
                f"max {dev.max * M_TO_MM:.1f} mm), {'refined' if refined else 'open-loop'} string lengths.")
    facts = [*_to_target(check), constructible, _tolerance(check)]
    if d.calibration.uncalibrated:
        facts.append(f"UNCALIBRATED: {d.calibration.label}.")
    folder = _folder(d)
    if ok is False:
        cmd, why = ("airmat design TARGET --out DIR",
                    "the design is not constructible: a gentler target or a larger mattress")
    elif not check.converged:
        cmd, why = "", "the inflation did not converge: these shapes are not equilibria (see the runs below)"
    elif not refined and d.pattern.strings:
        cmd, why = (f"airmat refine {folder} --out {folder}-refined",
                    "adjusts the string lengths together through the inflation (these are Equation 3's, one "
                    "dash at a time)")
    elif check.monte_carlo is None:
        cmd, why = (f"airmat check {folder} --samples {MC_SAMPLES} --out DIR",
                    f"the tolerance as a band: {MC_SAMPLES} inflations at sampled string lengths")
    else:
        cmd, why = ((f"airmat export {folder} --paper A4", f"the workshop files: {', '.join(WORKSHOP_FILES)} "
                     "and the 1:1 pattern on paper") if within else
                    ("", f"not within {WITHIN_PCT_DIAG:g} % even refined: a denser pattern or a gentler target"))
    kind = "bad" if ok is False or not check.converged else "ok" if within else "warn"
    return Verdict(kind, headline, tuple(facts), cmd, why)


def design_verdict(design) -> Verdict:
    """The verdict of a design alone: constructible, the refinement's promise if refined, the next command."""
    ok, constructible = _constructible(design)
    b, folder = design.refine, _folder(design)
    half = [0.5 * (s.l_hi95 - s.l_lo95) * M_TO_MM for s in design.pattern.strings]
    facts = [constructible]
    if half:
        facts.append(f"Tolerance: each string's 95 % length interval is ± {min(half):.1f} to ± {max(half):.1f} mm "
                     "(cutting list, lo95 – hi95).")
    if design.calibration.uncalibrated:
        facts.append(f"UNCALIBRATED: {design.calibration.label}.")
    if b and "deviation_after" not in b:        # corrected from a scan of the built mattress (airmat correct)
        after = b.get("rms_verified_mm") if b.get("rms_verified_mm") is not None else b.get("rms_linear_mm")
        headline = (f"Corrected from a scan of the built mattress: re-cut {b.get('recut', 0)} strings, keep "
                    f"{b.get('kept', 0)}; the face is predicted {after:.1f} mm RMS from Ŝ after the re-cut.")
        cmd, why = (f"airmat check {folder} --out DIR", "inflates the corrected lengths with their lo95 / hi95 "
                    "envelope")
        kind = "ok"
    elif b:
        a = b["deviation_after"]
        within = a["rms_pct_diag"] <= WITHIN_PCT_DIAG
        headline = (f"Lands within {WITHIN_PCT_DIAG:g} % of the diagonal: {'yes' if within else 'no'} (refined: "
                    f"the inflated {b['surface']} face {a['rms_mm']:.1f} mm RMS from Ŝ, {a['rms_pct_diag']:.2f} % "
                    f"of the diagonal, at {b['resolution_mm']:g} mm).")
        cmd, why = (f"airmat check {folder} --out DIR --resolution-mm {b['resolution_mm']:g}",
                    "inflates the refined lengths with their lo95 / hi95 envelope")
        kind = "ok" if within else "warn"
    else:
        headline = (f"Lands within {WITHIN_PCT_DIAG:g} % of the diagonal: not known yet (open-loop string "
                    "lengths, not inflated).")
        cmd, why = (f"airmat refine {folder} --out {folder}-refined",
                    "adjusts the string lengths together through the inflation and measures where it lands")
        kind = "warn"
    if ok is False:
        kind, cmd, why = "bad", "airmat design TARGET --out DIR", "a gentler target or a larger mattress"
    return Verdict(kind, headline, tuple(facts), cmd, why)


def calibration_verdict(cal) -> Verdict:
    """The verdict of a calibration alone: converged or not, Δ and d, the next command."""
    p = cal.posterior
    headline = (f"Calibrated{'' if p.converged else ', NOT converged'}: Δ = {p.delta.median * M_TO_MM:.1f} mm "
                f"[{p.delta.lo95 * M_TO_MM:.1f}, {p.delta.hi95 * M_TO_MM:.1f}], d = {p.d.median * M_TO_MM:.1f} mm "
                f"[{p.d.lo95 * M_TO_MM:.1f}, {p.d.hi95 * M_TO_MM:.1f}] (95 %).")
    facts = (f"{len(cal.specimens)} specimens; scatter σ = {p.sigma.median:.3f} 1/m.",)
    return Verdict("ok" if p.converged else "bad", headline, facts,
                   "airmat design --preset NAME --calibration CALIBRATION_DIR --out DIR",
                   "a string pattern with these string lengths")


def verdict_html(v: Verdict, *, see: tuple = ()) -> str:
    """The card: ``<div class="verdict KIND" id="verdict">`` with the headline, the facts and the next step.

    ``see``: ``(anchor id, text)`` pairs linked below the facts (the deviation map further down).
    """
    nxt = (f"<p class=\"next\">Next: <code>{escape(v.next_command)}</code>: {escape(v.next_why)}.</p>"
           if v.next_command else f"<p class=\"next\">Next: {escape(v.next_why)}.</p>")
    links = "".join(f'<li><a href="#{escape(a)}">{escape(t)}</a></li>' for a, t in see)
    return (f'<div class="verdict {escape(v.kind)}" id="verdict">\n<p class="headline">{escape(v.headline)}</p>\n'
            "<ul>" + "".join(f"<li>{escape(f)}</li>" for f in v.facts) + links + f"</ul>\n{nxt}\n</div>\n")
