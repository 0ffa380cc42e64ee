"""A small refinement case with a known answer: Ŝ is the inflated face of known string lengths."""

import numpy as np

from airmat.check.compare import surface_at
from airmat.check.length_map import length_map
from airmat.design.calibration_source import default_calibration
from airmat.design.mattress import Mattress
from airmat.design.pattern import Dash, Pattern, TensionString
from airmat.design.pipeline import DesignParams, DesignResult
from airmat.design.surface import ApproxSurface
from airmat.inflation.mesh import build_mattress_mesh
from airmat.inflation.simulate import inflate
from airmat.inflation.strings import StringSet

MATTRESS = Mattress(0.5, 0.4, 0.05)
RESOLUTION = 0.04
#: three bottom strings along u (Ω, m) and the simulated lengths that make Ŝ
A = np.array([[0.08, 0.1], [0.08, 0.2], [0.08, 0.3]])
B = np.array([[0.42, 0.1], [0.42, 0.2], [0.42, 0.3]])
TRUE_SIM = np.array([0.30, 0.28, 0.305])
#: open-loop lengths off the true ones (all shorter: every string stays taut)
OFF = np.array([-0.012, -0.006, -0.015])


def small_design(sim_lengths, *, true_sim=TRUE_SIM, n_samples=200):
    """A DesignResult whose Ŝ is the top face of the inflation with ``true_sim`` (m), strings at ``sim_lengths``."""
    m = MATTRESS
    mesh = build_mattress_mesh(m.width, m.height, m.thickness, resolution=RESOLUTION)
    truth = inflate(mesh, StringSet(A, B, np.zeros(3, bool), np.asarray(true_sim, float), ("a", "b", "c")))
    grid = build_mattress_mesh(m.width, m.height, m.thickness, resolution=0.05)
    uv = grid.uv[grid.top]
    xyz, _ = surface_at(truth, uv, "top")
    cal = default_calibration(d=m.thickness, n_samples=n_samples)
    real = length_map(cal).to_real(np.asarray(sim_lengths, float))
    strings = tuple(TensionString(dash=Dash(f"k1-00{i}-01", "k1", i, 1, np.array([A[i], B[i]]),
                                            float(np.linalg.norm(B[i] - A[i]))),
                                  kappa=1.0, side="bottom", l_median=float(real[i]), l_lo95=float(real[i]) - 0.003,
                                  l_hi95=float(real[i]) + 0.003) for i in range(3))
    approx = ApproxSurface(target=None, mattress=m, xyz=xyz, uv=uv, faces=grid.grid_faces, relax=None,
                           curvature=None, report=None)
    pattern = Pattern(strings=strings, L=0.34, n_dashes={"k1": 3, "k2": 0}, n_no_string={"k1": 0, "k2": 0})
    return DesignResult(name="small", approx=approx, pattern=pattern, calibration=cal,
                        params=DesignParams(L=0.34), seed=0)



def off_case():
    """A design whose open-loop lengths are OFF from the ones that made its Ŝ (the modules' ``case`` fixture)."""
    return small_design(TRUE_SIM + OFF)


def moves_toward_the_true_lengths(l_simulated):
    """Assert that refined lengths (m) moved from TRUE_SIM + OFF toward TRUE_SIM.

    The refinement sees the lengths only through the surface. All three strings shorter together (the
    common part, the mean) bends the whole face and is well observed; one string against its neighbours
    is not, since a string's effect is partly taken over by theirs. How far the differences go in a few
    Gauss–Newton iterations is therefore the conditioning of this three-string problem, which no design
    argument gives (measured between 0.65 and 0.71 of |OFF| as the solver changed), not a promise. The
    promise is the direction: the length vector ends closer to TRUE_SIM than it started (|OFF|), and so
    does its common part (|mean(OFF)|, 11 mm; measured 3.7 mm). Either fails if a step goes the wrong way.
    """
    err = np.asarray(l_simulated, float) - TRUE_SIM
    assert np.linalg.norm(err) < np.linalg.norm(OFF), err
    assert abs(err.mean()) < abs(OFF.mean()), err
