"""Physics of the inflation model: flat without strings, symmetric for a symmetric pattern, stable solver."""

import numpy as np
import pytest

from check.compare import surface_at
from inflation.mesh import build_mattress_mesh
from inflation.model import Parameters
from inflation.simulate import inflate
from inflation.strings import StringSet

W, H, D = 0.6, 0.4, 0.07


@pytest.fixture(scope="module")
def mesh():
    return build_mattress_mesh(W, H, D, resolution=0.05)


def test_no_strings_inflates_flat_to_thickness_d(mesh):
    r = inflate(mesh, None)
    assert r.converged and r.residual < 1e-6
    gap = np.linalg.norm(r.xyz[mesh.top] - r.xyz[mesh.bottom], axis=1)
    np.testing.assert_allclose(gap, D, rtol=5e-3)          # the pins hold the faces d apart
    mid = r.mid_surface
    normal = np.linalg.svd(mid - mid.mean(axis=0))[2][2]     # best-fit plane of the mid-surface
    assert np.abs((mid - mid.mean(axis=0)) @ normal).max() < 1e-3 * W


def _mirror_pairs(uv, axis):
    """Index map of grid points to their mirror image across the centre line ``axis`` (0: u, 1: v)."""
    size = (W, H)[axis]
    m = uv.copy()
    m[:, axis] = size - m[:, axis]
    key = {tuple(np.round(p, 9)): i for i, p in enumerate(uv)}
    return np.array([key[tuple(np.round(p, 9))] for p in m])


def _asymmetry(r, mesh, axis):
    """Largest difference of distance-to-centroid between mirrored grid points (m)."""
    mid = r.mid_surface - r.mid_surface.mean(axis=0)
    pair = _mirror_pairs(mesh.uv[mesh.top], axis)
    return np.abs(np.linalg.norm(mid, axis=1) - np.linalg.norm(mid[pair], axis=1)).max()


def test_symmetric_pattern_gives_symmetric_shape(mesh):
    # two bottom strings mirrored across u = W/2, each centred at v = H/2: symmetric under both mirrors
    a = np.array([[0.05, 0.2], [0.3, 0.2]])
    b = np.array([[0.3, 0.2], [0.55, 0.2]])
    sym = inflate(mesh, StringSet(a, b, np.zeros(2, bool), np.full(2, 0.18)))
    # control: the same strings, one of them moved off the mirror line
    a2, b2 = a.copy(), b.copy()
    a2[1, 1] = b2[1, 1] = 0.3
    asym = inflate(mesh, StringSet(a2, b2, np.zeros(2, bool), np.full(2, 0.18)))
    assert sym.converged and asym.converged
    for axis in (0, 1):
        # symmetric to 0.5 % of the width (the fold under each string is a soft mode the
        # solver's tolerance does not pin to the micrometre) ...
        assert _asymmetry(sym, mesh, axis) < 5e-3 * W
    # ... and far more symmetric than the control pattern
    assert _asymmetry(asym, mesh, 1) > 5 * _asymmetry(sym, mesh, 1)


def test_pressure_does_not_change_the_shape_much(mesh):
    a, b = np.array([[0.15, 0.2]]), np.array([[0.45, 0.2]])
    s = StringSet(a, b, np.array([True]), np.array([0.2]))
    r1 = inflate(mesh, s)
    r2 = inflate(mesh, s, params=Parameters(pressure=4000.0))
    uv = np.array([[0.1, 0.2], [0.3, 0.2], [0.5, 0.2], [0.3, 0.05]])
    p1, p2 = surface_at(r1, uv)[0], surface_at(r2, uv)[0]
    d1, d2 = np.linalg.norm(p1 - p1[1], axis=1), np.linalg.norm(p2 - p2[1], axis=1)
    np.testing.assert_allclose(d1, d2, atol=0.02 * W)
