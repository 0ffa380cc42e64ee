"""The U_B model and its Newton solver: mesh, exact derivatives, switches, divergence, residual."""

import numpy as np
import pytest
import trimesh

from airmat.errors import ConvergenceError, InputError
from airmat.inflation.assembly import build_assembler
from airmat.inflation.energy import (block_pattern, energy, energy_and_gradient, energy_gradient_volume, hessian_blocks,
                              pressure_forces, smoothing_blocks, spring_profile)
from airmat.inflation.mesh import build_mattress_mesh, locate
from airmat.inflation.model import Parameters, build_model
from airmat.inflation.simulate import inflate
from airmat.inflation.solver import rigid_pins, solve
from airmat.inflation.strings import StringSet, check_resolution

W, H, D = 0.5, 0.3, 0.07


@pytest.fixture(scope="module")
def mesh():
    return build_mattress_mesh(W, H, D, resolution=0.05)


def test_mesh_is_closed_outward_and_encloses_the_mattress(mesh):
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    assert tm.is_watertight and tm.is_winding_consistent
    assert tm.volume == pytest.approx(W * H * D, rel=1e-12)          # positive: outward normals
    nx, ny = mesh.grid_shape
    assert (nx - 1) % 2 == 0 and (ny - 1) % 2 == 0                   # even cells: mirror symmetric
    np.testing.assert_allclose(mesh.uv[mesh.top], mesh.uv[mesh.bottom])
    np.testing.assert_allclose(mesh.vertices[mesh.top, 2] - mesh.vertices[mesh.bottom, 2], D)


def test_locate_gives_barycentric_coordinates_that_rebuild_the_points(mesh):
    pts = np.random.default_rng(1).uniform([0, 0], [W, H], size=(500, 2))
    tri, bary = locate(mesh, pts)
    assert bary.min() > -1e-12 and np.allclose(bary.sum(axis=1), 1.0)
    rebuilt = np.einsum("kj,kjd->kd", bary, mesh.uv[mesh.top][tri])
    np.testing.assert_allclose(rebuilt, pts, atol=1e-12)


@pytest.mark.parametrize("compression", [0.0, 1e-2, 0.5])
def test_spring_profile_force_and_stiffness_are_continuous_derivatives(compression):
    w = 1e-3
    s = np.linspace(-5 * w, 5 * w, 20001)
    e, f, df = spring_profile(s, w, compression)
    h = s[1] - s[0]
    np.testing.assert_allclose(np.gradient(e, h)[1:-1], f[1:-1], atol=1e-6 * w)
    np.testing.assert_allclose(np.gradient(f, h)[2:-2], df[2:-2], atol=2e-3)
    assert np.all(np.abs(np.diff(f)) < 2 * h)                          # continuous force
    np.testing.assert_allclose(f[s >= 2 * w], s[s >= 2 * w] - (w if compression == 0 else 0.0))
    if compression == 0:
        assert np.all(f[s <= 0] == 0) and np.all(e[s <= 0] == 0)         # a slack string does nothing
    else:
        np.testing.assert_allclose(f[s >= 0], s[s >= 0])               # exact in tension


def _stretched_model(mesh):
    a, b = np.array([[0.1, 0.15]]), np.array([[0.4, 0.15]])
    strings = StringSet(a, b, np.array([True]), np.array([0.25]))
    model = build_model(mesh, strings, Parameters())
    rng = np.random.default_rng(3)
    x = mesh.vertices * 1.01 + rng.normal(scale=2e-4, size=mesh.vertices.shape)  # every spring taut
    return model, x, rng


def test_gradient_and_exact_hessian_match_finite_differences(mesh):
    model, x, rng = _stretched_model(mesh)
    e0, g = energy_and_gradient(model, x)
    d = rng.normal(size=x.shape) * 1e-7
    fd = (energy(model, x + d) - energy(model, x - d)) / 2
    assert fd == pytest.approx(np.sum(g * d), rel=1e-6)
    asm = build_assembler(block_pattern(model), model.n_vertices)
    hess = asm.assemble(hessian_blocks(model, x, project=False) + [smoothing_blocks(model)])
    g_fd = (energy_and_gradient(model, x + d)[1] - energy_and_gradient(model, x - d)[1]).ravel() / 2
    assert np.linalg.norm(hess @ d.ravel() - g_fd) < 1e-6 * np.linalg.norm(g_fd)
    assert abs(hess - hess.T).max() < 1e-9 * abs(hess).max()


def test_the_solver_s_volume_gradient_gives_the_pressure_forces_bit_for_bit(mesh):
    # the residual's reference force reuses the energy's dVol/dx instead of computing it again
    model, x, _ = _stretched_model(mesh)
    e, g, gv = energy_gradient_volume(model, x)
    e2, g2 = energy_and_gradient(model, x)
    assert e == e2 and np.array_equal(g, g2)
    assert np.array_equal(model.pressure * gv, pressure_forces(model, x))


def test_absurd_pressure_is_detected_as_divergence(mesh):
    with pytest.raises(ConvergenceError, match="stretched"):
        inflate(mesh, None, params=Parameters(pressure=2e7))       # 10^4 x the membrane's design pressure


def test_non_finite_start_raises(mesh):
    model = build_model(mesh, None)
    x = mesh.vertices.copy()
    x[5, 2] = np.nan
    with pytest.raises(ConvergenceError, match="non-finite"):
        solve(model, x, fixed_dofs=rigid_pins(mesh.uv, mesh.top))


def test_reported_residual_is_the_force_balance_of_the_result(mesh):
    a, b = np.array([[0.05, 0.15]]), np.array([[0.45, 0.15]])
    r = inflate(mesh, StringSet(a, b, np.array([False]), np.array([0.3])))
    assert r.converged and r.residual < 1e-6
    model = build_model(mesh, StringSet(a, b, np.array([False]), np.array([0.3])))
    g = energy_and_gradient(model, r.xyz)[1]
    free = np.ones(g.size, bool)
    free[rigid_pins(mesh.uv, mesh.top)] = False
    f_ref = np.linalg.norm(pressure_forces(model, r.xyz), axis=1).max()
    assert np.abs(g.ravel()[free]).max() / f_ref == pytest.approx(r.residual, rel=1e-6, abs=1e-12)
    # the string really pulls: its length is within the clamp onset of its rest length
    assert abs(r.string_lengths[0] - 0.3) < 5e-3 * 0.3
    # and the mattress bends away from the top (bottom string): the middle rises above the ends
    mid = r.mid_surface
    nx, ny = mesh.grid_shape
    row = (ny // 2) * nx + np.arange(nx)
    chord = mid[row[-1]] - mid[row[0]]
    up = np.cross(chord, mid[row[nx // 2] + nx] - mid[row[nx // 2]])    # top normal of that row
    assert np.dot(mid[row[nx // 2]] - 0.5 * (mid[row[0]] + mid[row[-1]]), up) > 0


def test_bad_string_placement_and_resolution_are_input_errors(mesh):
    s = StringSet(np.array([[0.1, 0.1], [0.1, 0.2]]), np.array([[0.4, 0.1], [0.6, 0.2]]),
                  np.array([True, False]), np.array([0.2, 0.3]), ("k1-000-00", "k2-007-03"))
    with pytest.raises(InputError, match="k2-007-03"):
        build_model(mesh, s)
    with pytest.raises(InputError, match="too coarse"):
        check_resolution(s, 0.1)
    with pytest.raises(InputError, match="limit"):
        build_mattress_mesh(2.6, 1.6, D, resolution=0.002)


class _CountingSystem:
    """A linear system of one unknown that counts its factorizations (``step`` calls)."""

    def __init__(self):
        self.calls = []

    def step(self, h, g, mu):
        self.calls.append(mu)
        return -g / (h[0, 0] + mu), mu


@pytest.mark.parametrize("rule, calls, mu", [("shift", 3, 8.0), ("backtrack", 1, 2.0)])
def test_a_refused_step_is_shifted_and_refactorized_or_halved_without_a_new_factorization(monkeypatch, rule, calls,
                                                                                           mu):
    import airmat.inflation.solver as sv

    # U(x) = (x - 1)² + 10 x⁴ from x = 0 with the Hessian of the quadratic part (2): the unshifted step (to
    # x = 1) raises U (11 > 1). "shift" factorizes again with the shift at its floor 0.5 (to x = 0.8, U = 4.1,
    # refused), then at 2 (x = 0.5, U = 0.875: taken); "backtrack" halves the first step to the same x = 0.5
    # without a new factorization. Either way the step realized 1/6 of its predicted decrease (< 1/4): the
    # shift is raised once more (x MU_UP) for the next iteration
    def egv(model, x):
        u = float(x[0, 0])
        grad = np.zeros_like(x)
        grad[0, 0] = 2.0 * (u - 1.0) + 40.0 * u ** 3
        return (u - 1.0) ** 2 + 10.0 * u ** 4, grad, np.zeros_like(x)

    monkeypatch.setattr(sv, "energy_gradient_volume", egv)
    monkeypatch.setattr(sv, "REFUSED_STEP", rule)
    monkeypatch.setattr(sv, "MU_UP", 4.0)
    tr = sv._TrustRegion(None, np.array([0]), np.inf, 0.005)
    system, x = _CountingSystem(), np.zeros((1, 3))
    e, g, _ = egv(None, x)
    xn, en, *_ = tr.step(system, np.array([[2.0]]), x, e, g.reshape(-1)[[0]])
    assert len(system.calls) == calls
    assert xn[0, 0] == pytest.approx(0.5)
    assert en == pytest.approx(0.875) and en < e
    assert tr.mu == pytest.approx(mu)


def test_both_rules_for_a_refused_step_land_on_the_same_equilibrium_of_one_bend(mesh, monkeypatch):
    import airmat.inflation.solver as sv

    strings = StringSet(np.array([[0.05, 0.15]]), np.array([[0.45, 0.15]]), np.array([False]), np.array([0.3]))
    shifted = inflate(mesh, strings)
    monkeypatch.setattr(sv, "REFUSED_STEP", "backtrack")
    monkeypatch.setattr(sv, "MU_UP", 2.0)
    halved = inflate(mesh, strings)
    assert shifted.converged and halved.converged
    assert np.abs(halved.xyz - shifted.xyz).max() < 1e-6      # m: the same equilibrium, by another path


def test_an_unknown_rule_for_a_refused_step_is_refused(mesh):
    model = build_model(mesh, None)
    with pytest.raises(ValueError, match="refused_step"):
        solve(model, mesh.vertices, fixed_dofs=rigid_pins(mesh.uv, mesh.top), refused_step="retry")
