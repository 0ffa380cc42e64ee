"""Design: target surface S -> near-developable Ŝ -> principal-curvature field on Ω -> string pattern.

Public API of the surface side (SI units: metres, 1/m):

- :class:`Mattress`, :func:`triangulate_mattress` -- Ω and its mesh (``design.mattress``).
- :class:`Target`, :func:`load_target` -- target meshes (``design.target``).
- :func:`relax_to_target` -- the U_A relaxation to Ŝ (``design.relax``).
- :func:`principal_curvature` -- per-vertex curvature of Ŝ (``design.curvature``).
- :func:`transfer_to_mattress` -- Ŝ -> Ω field (``design.transfer``).
- :func:`constructibility` -- Table-1 figures and verdict (``design.constructibility``).
- :func:`approximate_surface`, :func:`mattress_field` -- all of it in two calls (``design.surface``).
"""

import airmat  # noqa: F401  (sets the BLAS thread defaults before numpy loads)

from design.constructibility import ConstructibilityReport, constructibility
from design.curvature import PrincipalCurvature, principal_curvature
from design.field import FAMILIES, MattressField
from design.mattress import Mattress, triangulate_mattress
from design.placement import auto_placement, placement_matrix
from design.relax import RelaxResult, relax_to_target
from design.surface import ApproxSurface, approximate_surface, mattress_field
from design.target import Target, load_target
from design.transfer import transfer_to_mattress

__all__ = [
    "FAMILIES", "MattressField",
    "Mattress", "triangulate_mattress", "Target", "load_target", "auto_placement", "placement_matrix",
    "RelaxResult", "relax_to_target", "PrincipalCurvature", "principal_curvature",
    "transfer_to_mattress", "ConstructibilityReport", "constructibility",
    "ApproxSurface", "approximate_surface", "mattress_field",
]

# Pattern side: calibration source, stripes, string lengths, exports, the whole pipeline
from design.calibration_source import CalibrationSource, default_calibration, load_calibration  # noqa: E402
from design.pattern import Dash, Pattern, TensionString  # noqa: E402
from design.pipeline import DesignParams, DesignResult, design  # noqa: E402
from design.design_io import read_design, write_design  # noqa: E402
from design.string_lengths import string_pattern  # noqa: E402
from design.stripes import StripeParams, Stripes, trace_stripes  # noqa: E402

__all__ += [
    "CalibrationSource", "default_calibration", "load_calibration", "Dash", "Pattern", "TensionString",
    "StripeParams", "Stripes", "trace_stripes", "string_pattern",
    "DesignParams", "DesignResult", "design", "write_design", "read_design",
]
