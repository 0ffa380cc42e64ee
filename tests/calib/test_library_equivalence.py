"""The fit's numpy-only pieces against the libraries they stand in for (scipy, scikit-image).

``airmat.calib.circle_ransac`` and ``airmat.calib.cylinder_lsq.refine`` replace
``skimage.measure.ransac(CircleModel)`` and ``scipy.optimize.least_squares``
on the fit's path only because importing those libraries costs more than the
whole fit (docs/benchmarks.md, ``bench/bench_cylinder.py --process``); these tests hold them to the
libraries' answers on the same problems.
"""

import numpy as np
import pytest

from airmat.calib.circle_ransac import circle_ransac
from airmat.calib.cylinder_lsq import CylinderFrame, CylinderProblem, refine, rotation_matrix


def _arc_with_outliers(seed, n=400, outliers=120, radius=1.3, noise=0.004):
    rng = np.random.default_rng(seed)
    t = rng.uniform(-1.0, 1.0, n)
    pts = np.column_stack([radius * np.sin(t), radius * (1 - np.cos(t))]) + rng.normal(0, noise, (n, 2))
    junk = rng.uniform([-1.2, -0.3], [1.2, 1.0], (outliers, 2))
    return np.concatenate([pts, junk]), radius, np.array([0.0, radius])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_circle_ransac_finds_the_circle_skimage_finds(seed):
    from skimage.measure import CircleModel, ransac

    pts, radius, center = _arc_with_outliers(seed)
    ours = circle_ransac(pts, threshold=0.015, max_trials=300, seed=seed)
    model, inliers = ransac(pts, CircleModel, min_samples=3, residual_threshold=0.015, max_trials=300,
                            rng=seed)
    sk_center, sk_radius = np.asarray(model.center), float(model.radius)
    # both recover the truth to the noise, and agree with each other as closely
    assert abs(ours.radius - radius) < 0.01 and np.linalg.norm(ours.center - center) < 0.01
    assert abs(ours.radius - sk_radius) < 0.01 and np.linalg.norm(ours.center - sk_center) < 0.01
    # the same consensus set but for points right at the threshold
    assert np.mean(ours.inliers != inliers) < 0.02


def test_rotation_matrix_is_scipys():
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(3)
    for w in list(rng.normal(0, 1.0, (20, 3))) + [np.array([1e-9, -2e-8, 3e-9]), np.zeros(3)]:
        np.testing.assert_allclose(rotation_matrix(w), Rotation.from_rotvec(w).as_matrix(), atol=1e-14)


@pytest.mark.parametrize("loss", ["soft_l1", "huber", "cauchy", "linear"])
def test_refine_reaches_the_optimum_of_scipy_least_squares(loss):
    """Same residuals, same robust loss, same start: the same minimum of the cost (to 1e-10), so the
    same cylinder to far below its standard error (the cost is flat there: 1e-6 in kappa)."""
    from scipy.optimize import least_squares

    from airmat.calib.cylinder_irls import robust_cost
    from airmat.calib.cylinder_lsq import residuals

    rng = np.random.default_rng(7)
    R, n = 0.25, 3000
    t, y = rng.uniform(-0.8, 0.8, n), rng.uniform(-0.2, 0.2, n)
    pts = np.column_stack([R * np.sin(t), y, R * (1 - np.cos(t))]) + rng.normal(0, 5e-4, (n, 3))
    pts[:150] += rng.normal(0, 0.02, (150, 3))                    # 5 % gross outliers
    start = CylinderFrame(origin=np.array([0.01, 0.0, 0.002]), normal=np.array([0.05, 0.0, 1.0]) / np.hypot(0.05, 1),
                          axis=np.array([0.0, 1.0, 0.0]), kappa=3.2)
    ours = refine(pts, start, f_scale=5e-4, loss=loss)
    prob = CylinderProblem(pts, start)
    ref = least_squares(prob.fun, prob.x0(), jac=prob.jac, loss=loss, f_scale=5e-4 / prob.scale,
                        xtol=1e-12, ftol=1e-12, gtol=1e-12, method="trf")
    theirs = prob.frame(ref.x)
    assert ours.converged
    f = 5e-4 / prob.scale
    cost = [robust_cost(residuals(pts, fr) / prob.scale, f, loss) for fr in (ours.frame, theirs)]
    assert cost[0] == pytest.approx(cost[1], rel=1e-10)
    assert ours.frame.kappa == pytest.approx(theirs.kappa, rel=1e-6)
    np.testing.assert_allclose(abs(ours.frame.axis @ theirs.axis), 1.0, atol=1e-10)
    if loss != "linear":                         # the robust losses see through the 5 % outliers
        assert 1.0 / ours.frame.kappa == pytest.approx(R, rel=2e-3)
