"""Write a synthetic scan in a scanner's format, with the library real software uses for it.

Test data for :mod:`airmat.calib.scan_readers`: every file is written by a third-party
writer (pye57, laspy with lazrs, open3d, trimesh) or, for the column formats,
in the layouts Metashape/CloudCompare/Leica export, so the readers are tested
against files they did not write themselves. Coordinates are given in
millimetres and written in the format's unit (metres for E57 and LAS/LAZ).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

__all__ = ["FORMATS", "write_scan"]

#: format name -> file suffix
FORMATS = {
    "e57": ".e57", "las": ".las", "laz": ".laz", "laz14": ".laz", "pcd_ascii": ".pcd", "pcd_binary": ".pcd",
    "pcd_compressed": ".pcd", "glb": ".glb", "pts": ".pts", "xyz": ".xyz", "txt": ".txt",
    "ply": ".ply",
}


def write_scan(path: str | os.PathLike, points_mm, fmt: str, *, poses=None, seed=0) -> Path:
    """Write ``points_mm`` (N, 3), millimetres, as format ``fmt`` (a key of :data:`FORMATS`).

    Parameters
    ----------
    path : path
        Output file; its suffix should be ``FORMATS[fmt]``.
    points_mm : array_like of shape (N, 3)
        Coordinates (mm).
    fmt : str
        The format and flavour ("laz": LAS 1.2 point format 3; "laz14": LAS
        1.4 point format 6).
    poses : list of (rotation (3, 3), translation (3,) mm), optional
        E57 only: split the points into ``len(poses)`` scans, each stored in
        its scanner's frame with its pose (the reader must apply them).
    seed : int
        Seed of the intensity/colour columns and of the split into scans.

    Returns
    -------
    Path
    """
    path = Path(path)
    pts = np.asarray(points_mm, dtype=float)
    rng = np.random.default_rng(seed)
    writer = {"e57": _e57, "las": _las, "laz": _las, "laz14": _las14, "glb": _glb, "ply": _trimesh_cloud}.get(fmt)
    if fmt.startswith("pcd"):
        _pcd(path, pts, fmt.split("_")[1])
    elif fmt in ("pts", "xyz", "txt"):
        _text(path, pts, fmt, rng)
    elif writer is _e57:
        _e57(path, pts, poses, rng)
    elif writer is _las14:
        _las14(path, pts, rng)
    else:
        writer(path, pts)
    return path


def _e57(path, pts, poses, rng):
    import pye57

    poses = poses or [(np.eye(3), np.zeros(3))]
    owner = rng.integers(0, len(poses), len(pts))
    e57 = pye57.E57(str(path), mode="w")
    try:
        for k, (rot, trans_mm) in enumerate(poses):
            world = pts[owner == k] * 1e-3
            local = (world - np.asarray(trans_mm) * 1e-3) @ np.asarray(rot)  # R^T (x - t)
            quat = _quaternion(np.asarray(rot))
            e57.write_scan_raw({"cartesianX": local[:, 0], "cartesianY": local[:, 1],
                                "cartesianZ": local[:, 2]},
                               name=f"scan {k}", rotation=quat, translation=np.asarray(trans_mm) * 1e-3)
    finally:
        e57.close()


def _quaternion(rot):
    """(w, x, y, z) of a rotation matrix."""
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(rot).as_quat()
    return np.array([w, x, y, z])


def _las(path, pts):
    import laspy

    m = pts * 1e-3
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.offsets = np.floor(m.min(axis=0))
    header.scales = np.array([1e-5, 1e-5, 1e-5])  # 0.01 mm
    las = laspy.LasData(header)
    las.x, las.y, las.z = m[:, 0], m[:, 1], m[:, 2]
    las.write(str(path))  # .laz compresses with lazrs


def _las14(path, pts, rng):
    """LAS 1.4, point format 6 (what current scanner and photogrammetry software writes), with intensity,
    returns and GPS time: in a LAZ each is its own compressed layer."""
    import laspy

    m = pts * 1e-3
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.offsets = np.floor(m.min(axis=0))
    header.scales = np.array([1e-5, 1e-5, 1e-5])
    las = laspy.LasData(header)
    las.x, las.y, las.z = m[:, 0], m[:, 1], m[:, 2]
    las.intensity = rng.integers(0, 65536, len(m))
    las.return_number = las.number_of_returns = np.ones(len(m), np.uint8)
    las.gps_time = np.arange(len(m)) * 1e-6
    las.write(str(path))


def _pcd(path, pts, flavour):
    from airmat.lazy import import_open3d

    o3d = import_open3d()

    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts))
    o3d.io.write_point_cloud(str(path), cloud, write_ascii=flavour == "ascii",
                             compressed=flavour == "compressed")


def _glb(path, pts):
    import trimesh

    trimesh.PointCloud(pts.astype(np.float32)).export(str(path), file_type="glb")


def _trimesh_cloud(path, pts):
    import trimesh

    trimesh.PointCloud(pts).export(str(path), file_type="ply", encoding="binary")


def _text(path, pts, fmt, rng):
    """``.pts``: count line, x y z intensity r g b (Leica/Metashape); ``.xyz``: x y z;
    ``.txt``: a CloudCompare header ``//X,Y,Z,Intensity`` and comma-separated columns."""
    n = len(pts)
    inten = rng.integers(0, 2048, n)
    if fmt == "pts":
        rgb = rng.integers(0, 256, (n, 3))
        table = np.column_stack([pts, inten, rgb])
        np.savetxt(path, table, fmt=["%.4f"] * 3 + ["%d"] * 4, header=str(n), comments="")
    elif fmt == "xyz":
        np.savetxt(path, pts, fmt="%.4f")
    else:
        np.savetxt(path, np.column_stack([pts, inten]), fmt=["%.4f"] * 3 + ["%d"], delimiter=",",
                   header="//X,Y,Z,Intensity", comments="")
