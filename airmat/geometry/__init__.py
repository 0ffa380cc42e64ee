"""Geometry shared by the designer, the simulator and the synthetic data.

- ``airmat.geometry.grid`` -- the structured triangulation of a rectangle (Ω), with
  alternating or union-jack diagonals, and a parametric mesh over a rectangle.
- ``airmat.geometry.topology`` -- mesh edges, boundary, the flat cotangent Laplacian.
- ``airmat.geometry.polyline`` -- arc length and resampling of polylines.
- ``airmat.geometry.graph_curvature`` -- exact principal curvatures of a graph z = h(x, y).

The modules import nothing from the packages that use them (design, inflation,
check, data_synthetic); import them directly, this package re-exports nothing.
"""
