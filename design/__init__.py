"""Design: target surface S -> near-developable Ŝ -> principal-curvature field on Ω -> string pattern.

Public API of the surface side (SI units: metres, 1/m):

- :class:`Mattress`, :func:`triangulate_mattress` -- Ω and its mesh (``airmat.design.mattress``).
- :class:`Target`, :func:`load_target` -- target meshes (``airmat.design.target``).
- :func:`relax_to_target` -- the U_A relaxation to Ŝ (``airmat.design.relax``).
- :func:`principal_curvature` -- per-vertex curvature of Ŝ (``airmat.design.curvature``).
- :func:`transfer_to_mattress` -- Ŝ -> Ω field (``airmat.design.transfer``).
- :func:`constructibility` -- Table-1 figures and verdict (``airmat.design.constructibility``).
- :func:`approximate_surface`, :func:`mattress_field` -- all of it in two calls (``airmat.design.surface``).

Pattern side: the calibration source, stripes, string lengths, exports and the whole pipeline
(:func:`design`, :func:`write_design` in ``airmat.design.pipeline``).
"""

import airmat  # noqa: F401  (sets the BLAS thread defaults before numpy loads)
from airmat.lazy import attach

# public name -> its submodule, imported on first use (``airmat.lazy``): ``import airmat.design.mattress``
# runs this file first, and it must not load the pipeline, ezdxf or matplotlib
__getattr__, __dir__, __all__ = attach(__name__, {
    "field": ["FAMILIES", "MattressField"],
    "mattress": ["Mattress", "triangulate_mattress"],
    "target": ["Target", "load_target"],
    "placement": ["auto_placement", "placement_matrix"],
    "relax": ["RelaxResult", "relax_to_target"],
    "curvature": ["PrincipalCurvature", "principal_curvature"],
    "transfer": ["transfer_to_mattress"],
    "constructibility": ["ConstructibilityReport", "constructibility"],
    "surface": ["ApproxSurface", "approximate_surface", "mattress_field"],
    "calibration_source": ["CalibrationSource", "default_calibration", "load_calibration"],
    "pattern": ["Dash", "Pattern", "TensionString"],
    "stripes": ["StripeParams", "Stripes", "trace_stripes"],
    "string_lengths": ["string_pattern"],
    "pipeline": ["DesignParams", "DesignResult", "design"],
    "design_io": ["read_design", "write_design"],
    "retie": ["RetiePlan", "retie_plan"],
    "tie_grid": ["snap_dashes", "TieGridReport"],
})
