"""The straightforward open3d + least-squares cylinder fit that airmat is benchmarked against.

The plain recipe: open3d voxel downsampling and plane removal, open3d
normals, axis = smallest eigenvector of the normals' scatter, circle by
RANSAC in the projection (skimage), then scipy least_squares (soft_l1,
scale from the MAD of the start's residuals) over axis, centre and radius
on the points near that circle.

As a script it is the whole process a user would write: read a scan with
open3d, fit, print the radius:

    .venv/bin/python bench/recipe_cylinder.py SCAN.ply     # prints {"radius_mm": ...}
"""

from __future__ import annotations

import json
import sys

import numpy as np


def recipe_fit(points, seed=0):
    """The plain recipe (see the module docstring); returns the radius (in the points' unit)."""
    import open3d as o3d
    from scipy.optimize import least_squares

    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    o3d.utility.random.seed(seed)
    diag = float(np.linalg.norm(np.ptp(points, axis=0)))
    thresh = 2e-3 * diag
    down = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points)).voxel_down_sample(diag / 150)
    (a, b, c, d), _ = down.segment_plane(thresh, 3, 1000)
    keep = np.abs(points @ np.array([a, b, c]) + d) / np.linalg.norm([a, b, c]) > thresh
    rest = points[keep]
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(rest)).voxel_down_sample(diag / 150)
    cloud.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(knn=20))
    nrm = np.asarray(cloud.normals)
    axis = np.linalg.eigh(nrm.T @ nrm)[1][:, 0]
    e1 = np.cross(axis, np.eye(3)[np.argmin(np.abs(axis))])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    uv = np.asarray(cloud.points) @ np.column_stack([e1, e2])
    from skimage.measure import CircleModel, ransac

    model, _ = ransac(uv, CircleModel, 3, thresh, max_trials=500, rng=seed)
    sol, r0 = np.asarray(model.center), float(model.radius)
    o = float(np.mean(rest @ axis))
    dist = np.abs(np.linalg.norm(rest @ np.column_stack([e1, e2]) - sol, axis=1) - r0)
    rest = rest[dist < 3 * thresh]  # the points near the circle

    def resid(x):
        ax = axis + x[0] * e1 + x[1] * e2
        ax /= np.linalg.norm(ax)
        cen = (sol[0] + x[2]) * e1 + (sol[1] + x[3]) * e2 + o * axis
        w = rest - cen
        return np.linalg.norm(w - np.outer(w @ ax, ax), axis=1) - x[4]

    x0 = np.array([0.0, 0.0, 0.0, 0.0, r0])
    f_scale = 1.4826 * np.median(np.abs(resid(x0))) + 1e-9
    res = least_squares(resid, x0, loss="soft_l1", f_scale=f_scale, x_scale="jac", max_nfev=50)
    return float(res.x[4])


def main(argv=None):
    import open3d as o3d

    path = (sys.argv[1:] if argv is None else argv)[0]
    points = np.asarray(o3d.io.read_point_cloud(path).points, dtype=float)
    json.dump({"radius_mm": recipe_fit(points)}, sys.stdout)
    sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
