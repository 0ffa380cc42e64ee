"""Where Ω starts on the target S: a rigid map from Ω's frame into space.

A placement is a 4 × 4 homogeneous matrix ``T`` taking a point (u, v, 0) of
Ω (m, origin at Ω's corner, +z the top normal) to space. By default Ω is
laid flat on S's principal plane: centred on S, its long side along S's
longest direction (PCA of S's area-weighted face centroids), its top
normal on the side S's face normals point to, and touching S where the
normal axis through S's centroid meets it. :func:`candidate_placements`
adds that placement turned by 90°, 180° and 270° about the normal, for a
caller (airmat.design.relax) that keeps the one S accommodates best: S's longest
straight extent is not always its longest unrolled one (a cylinder with
more arc than axis).
"""

from __future__ import annotations

import numpy as np

from airmat.errors import InputError

__all__ = ["auto_placement", "candidate_placements", "placement_matrix", "apply_placement"]


def _pca_frame(target) -> tuple[np.ndarray, np.ndarray]:
    """Area-weighted centroid (3,) and principal axes (3, 3), columns by decreasing variance."""
    cross = target.face_cross
    area = 0.5 * np.linalg.norm(cross, axis=1)
    centres = target.vertices[target.faces].mean(axis=1)
    mean = area @ centres / area.sum()
    d = centres - mean
    cov = (d * area[:, None]).T @ d / area.sum()
    _, vecs = np.linalg.eigh(cov)
    axes = vecs[:, ::-1].copy()
    # deterministic signs: the normal to the side of S's face normals (else +z), the long axis
    # with its largest component positive
    mean_normal = cross.sum(axis=0)
    ref = mean_normal if np.linalg.norm(mean_normal) > 1e-6 * area.sum() else np.array([0.0, 0.0, 1.0])
    if axes[:, 2] @ ref < 0:
        axes[:, 2] *= -1
    if axes[np.argmax(np.abs(axes[:, 0])), 0] < 0:
        axes[:, 0] *= -1
    axes[:, 1] = np.cross(axes[:, 2], axes[:, 0])
    return mean, axes


def auto_placement(target, width: float, height: float, *, projector=None) -> np.ndarray:
    """The default placement of Ω = [0, W] × [0, H] on ``target``.

    Parameters
    ----------
    target : airmat.design.target.Target
    width, height : float
        W and H of Ω (m).
    projector : airmat.design.closest_point.MeshProjector, optional
        A BVH over the target (built when not given).

    Returns
    -------
    ndarray of shape (4, 4)
        The placement matrix: Ω's centre lands on S where S's normal axis through
        its centroid meets S (nearest hit; the closest point when the axis misses S),
        Ω's longer side along S's longest principal direction.
    """
    from airmat.design.closest_point import MeshProjector

    mean, axes = _pca_frame(target)
    n, long_axis = axes[:, 2], axes[:, 0]
    if width >= height:
        a_u = long_axis
        a_v = np.cross(n, a_u)
    else:
        a_v = long_axis
        a_u = np.cross(a_v, n)
    projector = projector or MeshProjector(target.vertices, target.faces)
    t = projector.first_hit(np.array([mean, mean]), np.array([n, -n]))
    if np.isfinite(t).any():
        k = int(np.argmin(t))
        centre = mean + (n if k == 0 else -n) * t[k]
    else:
        centre = projector.closest(mean[None]).points[0]
    rot = np.column_stack([a_u, a_v, n])
    return placement_matrix((centre, rot), width, height)


def candidate_placements(target, width: float, height: float, *, projector=None) -> list[np.ndarray]:
    """:func:`auto_placement` and the same placement turned by 90°, 180° and 270° about its normal.

    Parameters
    ----------
    target : airmat.design.target.Target
    width, height : float
        W and H of Ω (m).
    projector : airmat.design.closest_point.MeshProjector, optional
        A BVH over the target.

    Returns
    -------
    list of ndarray of shape (4, 4)
        Four placement matrices, :func:`auto_placement` first; all put Ω's centre on the
        same point of S with the same top normal.
    """
    first = auto_placement(target, width, height, projector=projector)
    centre = apply_placement(first, np.array([[0.5 * width, 0.5 * height]]))[0]
    u, v, n = first[:3, 0], first[:3, 1], first[:3, 2]
    out = [first]
    for c, s in ((0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)):
        rot = np.column_stack([c * u + s * v, -s * u + c * v, n])
        out.append(placement_matrix((centre, rot), width, height))
    return out


def placement_matrix(placement, width: float, height: float) -> np.ndarray:
    """Normalise a placement to a 4 × 4 matrix.

    Parameters
    ----------
    placement : ndarray of shape (4, 4) or tuple (offset, rotation)
        Either the matrix itself (maps (u, v, 0, 1) with Ω's corner at the
        origin), or ``offset`` (3,): where Ω's centre (W/2, H/2) goes (m), and
        ``rotation`` (3, 3): a rotation whose columns are Ω's u axis, v axis
        and top normal in space.
    width, height : float
        W and H of Ω (m).

    Raises
    ------
    airmat.errors.InputError
        When the matrix is not a rigid motion (rotation with det +1, last row 0 0 0 1).
    """
    if isinstance(placement, tuple):
        if len(placement) != 2:
            raise InputError("placement tuple must be (offset (3,), rotation (3, 3))")
        offset, rot = (np.asarray(p, dtype=float) for p in placement)
        if offset.shape != (3,) or rot.shape != (3, 3):
            raise InputError(f"placement offset/rotation have shapes {offset.shape}/{rot.shape}, "
                             "expected (3,)/(3, 3)")
        mat = np.eye(4)
        mat[:3, :3] = rot
        mat[:3, 3] = offset - rot @ np.array([0.5 * width, 0.5 * height, 0.0])
    else:
        mat = np.asarray(placement, dtype=float)
        if mat.shape != (4, 4):
            raise InputError(f"placement matrix has shape {mat.shape}, expected (4, 4)")
    rot = mat[:3, :3]
    if (not np.isfinite(mat).all() or not np.allclose(rot.T @ rot, np.eye(3), atol=1e-6)
            or np.linalg.det(rot) < 0 or not np.allclose(mat[3], [0, 0, 0, 1])):
        raise InputError("placement must be a rigid motion: an orthonormal rotation with "
                         "determinant +1 and last row (0, 0, 0, 1)", placement=mat)
    return mat


def apply_placement(mat: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Positions (n, 3) in space (m) of Ω points ``uv`` (n, 2) under placement ``mat`` (4, 4)."""
    return uv @ mat[:3, :2].T + mat[:3, 3]
