"""The check: inflate a design with its strings and measure how far it lands from Ŝ.

Public API (SI units: metres, 1/m):

- :func:`check` -- inflate a :class:`~design.pipeline.DesignResult` at the median string
  lengths and at both tolerance ends, and K Monte-Carlo samples of them (``inflation_check``).
- :class:`MonteCarloDraws`, :class:`MonteCarloResult` -- the sampled string lengths and the
  statistics of their runs (``monte_carlo``).
- :func:`deviation`, :func:`realized_curvature`, :func:`surface_at` -- an inflation against Ŝ on a
  named face (:func:`length_keeping_face`: the face opposite the strings) (``compare``).
- :func:`write_check` -- ``inflate.json``, ``inflated.ply``, ``inflated.3dm``, ``deviation.png`` (``report``).
- :func:`validate_equation3` -- the paper's specimen experiment, simulated (``validation``).
"""

import airmat  # noqa: F401  (sets the BLAS thread defaults before numpy loads)
from airmat.lazy import attach

# public name -> its submodule, imported on first use (``airmat.lazy``)
__getattr__, __dir__, __all__ = attach(__name__, {
    "compare": ["SURFACES", "Deviation", "deviation", "length_keeping_face", "realized_curvature",
                "surface_at"],
    "inflation_check": ["CheckRun", "DesignCheck", "check", "design_strings"],
    "length_map": ["LengthMap", "length_map"],
    "monte_carlo": ["MonteCarloDraws", "MonteCarloResult"],
    "report": ["write_check"],
    "validation": ["validate_equation3"],
})
