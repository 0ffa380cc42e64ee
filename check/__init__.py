"""The check: inflate a design with its strings and measure how far it lands from Ŝ.

Public API (SI units: metres, 1/m):

- :func:`check` -- inflate a :class:`~airmat.design.pipeline.DesignResult` at the median string
  lengths and at both tolerance ends, and K Monte-Carlo samples of them (``inflation_check``).
- :class:`MonteCarloDraws`, :class:`MonteCarloResult` -- the sampled string lengths and the
  statistics of their runs (``monte_carlo``).
- :func:`deviation`, :func:`realized_curvature`, :func:`surface_at` -- an inflation against Ŝ on a
  named face (:func:`airmat.design.face_metric.length_keeping_face`: the face opposite the strings) (``compare``).
- :func:`write_check` -- ``inflate.json``, ``inflated.ply``, ``inflated.3dm``, ``deviation.png`` (``report``).
- :func:`refine` -- the string lengths refined through the inflated equilibrium (adjoint
  Gauss–Newton), a refined DesignResult and its ``refine`` block, tuned by :class:`RefineOptions`
  (``refinement``, ``gauss_newton``, ``adjoint``, ``refine_objective``).
- :func:`airmat.check.tolerance.tolerance` (``airmat.tolerance``) -- the tolerance to first order: the adjoint Jacobian at the median run times the
  covariance of the string lengths (:func:`length_covariance`), checked against a few full samples (``tolerance``).
- :func:`validate_equation3` -- the paper's specimen experiment, simulated (``validation``).
- :func:`length_map` -- real string length -> simulated rest length: l + 2Δ (:class:`LengthMap`) or
  calibrated on simulated specimens (:class:`CalibratedLengthMap`, cached; ``length_map``, ``calibrated_map``).
"""

import airmat  # noqa: F401  (sets the BLAS thread defaults before numpy loads)
from airmat.lazy import attach

# public name -> its submodule, imported on first use (``airmat.lazy``)
__getattr__, __dir__, __all__ = attach(__name__, {
    "compare": ["SURFACES", "Deviation", "deviation", "realized_curvature",
                "surface_at"],
    "inflation_check": ["CheckRun", "DesignCheck", "KnownRun", "check", "design_strings"],
    "calibrated_map": ["calibrated_length_map"],
    "length_map": ["LengthMap", "CalibratedLengthMap", "length_map"],
    "monte_carlo": ["MonteCarloDraws", "MonteCarloResult"],
    "report": ["write_check"],
    "refinement": ["refine", "check_refinable"],
    "refinement_result": ["Refinement", "RefineOptions"],
    "refined_design": ["refined_design", "REFINE_FLAG"],
    "adjoint": ["rest_derivative", "factor_equilibrium", "equilibrium_jacobian", "adjoint_gradient"],
    "refine_objective": ["face_operator", "face_fit"],
    "validation": ["validate_equation3"],
    "tolerance": ["LinearTolerance", "Validation"],
    "length_covariance": ["LengthCovariance", "length_covariance"],
})
