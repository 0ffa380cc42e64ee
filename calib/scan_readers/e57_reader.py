"""E57 (ASTM E2807) through pye57: one scan, or every scan merged with its pose.

E57 coordinates are metres by the standard. Each scan's pose (rotation and
translation in the file) is applied, so merged scans share one frame.
Points flagged invalid by the scanner (``cartesianInvalidState`` != 0) come
back as NaN, so they are counted with the other non-finite points.

A cartesian scan is decoded by libE57 (pye57's binding) straight into the
columns of one (N, 3) float64 array, reading only x, y, z and the invalid
flag; the pose is one matrix product, skipped when it is the identity.
``pye57.E57.read_scan`` reads each field into its own array and stacks and
transposes the points for the pose, even the identity: 3 times the CPU time
on a 1M-point scan. Spherical scans go through it (it converts them).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from airmat.errors import InputError
from airmat.calib.scan_readers.raw import RawCloud, check_step, library_message

__all__ = ["read"]


def read(path: Path, *, scan_index: int | None = None) -> RawCloud:
    """Points of scan ``scan_index`` (all scans, merged with their poses, when None), metres."""
    try:
        import pye57
    except ImportError:
        raise InputError("reading E57 needs pye57, which is not installed (it has no wheel for Intel macOS): "
                         "save the scan as PLY or LAS (CloudCompare: File > Save as)", path=path) from None

    try:
        e57 = pye57.E57(str(path), mode="r")
    except Exception as err:  # libE57 raises its own exception types
        raise InputError(f"cannot parse E57 file (truncated or corrupt?): {library_message(err)}",
                         path=path) from None
    try:
        n = e57.scan_count
        if n == 0:
            raise InputError("no scans in the E57 file", path=path)
        if scan_index is not None and not 0 <= scan_index < n:
            raise InputError(f"--scan-index {scan_index} out of range: the file holds {n} scan(s) "
                             f"(0..{n - 1})", path=path)
        indices = range(n) if scan_index is None else [scan_index]
        parts, steps = zip(*(_scan_points(e57, i, path) for i in indices))
    finally:
        e57.close()
    return RawCloud(vertices=parts[0] if len(parts) == 1 else np.concatenate(parts), units="m", n_scans=n,
                    step=max(steps))


#: the cartesian coordinate fields, in output column order
_XYZ = ("cartesianX", "cartesianY", "cartesianZ")


def _scan_points(e57, i: int, path: Path) -> tuple[np.ndarray, float]:
    """Scan ``i``'s points in the file's frame (its pose applied), metres, invalid ones NaN, and the step of its
    stored coordinates (m; before the pose, which libE57 keeps in double precision)."""
    try:
        header = e57.get_header(i)
        if set(_XYZ) <= set(header.point_fields):
            xyz = _read_cartesian(e57, header)
            step = _stored_step(header, xyz, path)
            if header.has_pose():
                rot, shift = header.rotation_matrix, np.asarray(header.translation, float)
                if not (np.array_equal(rot, np.eye(3)) and not shift.any()):
                    xyz = xyz @ rot.T
                    xyz += shift
            return xyz, step
    except InputError:
        raise
    except Exception as err:
        raise InputError(f"cannot read scan {i} of the E57 file: {library_message(err)}",
                         path=path) from None
    try:
        data = e57.read_scan(i, ignore_missing_fields=True, transform=True)
    except Exception as err:
        raise InputError(f"cannot read scan {i} of the E57 file: {library_message(err)}",
                         path=path) from None
    if "cartesianX" not in data:
        raise InputError(f"scan {i} of the E57 file has no cartesian coordinates", path=path)
    # spherical scans: pye57 converts them and leaves out the records flagged invalid
    return np.column_stack([data["cartesianX"], data["cartesianY"], data["cartesianZ"]]).astype(float), 0.0


def _stored_step(header, xyz: np.ndarray, path: Path) -> float:
    """Step of the stored x (m): the scale of scaled integers, the spacing of single floats at the scan's
    largest coordinate; 0 for doubles. A step too coarse for any surface is refused here."""
    from pye57 import libe57

    node = libe57.StructureNode(header.points.prototype()).get(_XYZ[0])
    if node.type() == libe57.NodeType.E57_SCALED_INTEGER:
        step = float(libe57.ScaledIntegerNode(node).scale())
        what = f"the E57 scan stores integers times its scale {step:g} m"
    elif node.type() == libe57.NodeType.E57_FLOAT and \
            libe57.FloatNode(node).precision() == libe57.FloatPrecision.E57_SINGLE:
        with np.errstate(invalid="ignore"):
            largest = float(np.nanmax(np.abs(xyz))) if np.isfinite(xyz).any() else 0.0
        step = float(np.spacing(np.float32(largest)))
        what = "stored as 32-bit floats far from the origin"
    else:
        return 0.0
    check_step(xyz, step, path, what, "export it in double precision or re-centred (CloudCompare: "
               "Edit > Apply transformation, then save as E57 or LAS)")
    return step


def _read_cartesian(e57, header) -> np.ndarray:
    """x, y, z of every record, float64 (N, 3): libE57 writes each into its column (a strided buffer)."""
    from pye57 import libe57

    n = header.point_count
    xyz = np.empty((n, 3))
    buffers = libe57.VectorSourceDestBuffer()
    for j, name in enumerate(_XYZ):  # doConversion, doScaling: scaled integers and floats to double
        buffers.append(libe57.SourceDestBuffer(e57.image_file, name, xyz[:, j], n, True, True, xyz.strides[0]))
    invalid = None
    if "cartesianInvalidState" in header.point_fields:
        invalid = np.empty(n, np.int8)
        buffers.append(libe57.SourceDestBuffer(e57.image_file, "cartesianInvalidState", invalid, n, True, True))
    reader = header.points.reader(buffers)
    try:
        got = reader.read()
    finally:
        reader.close()
    if got != n:
        raise ValueError(f"read {got} of {n} records")
    if invalid is not None:
        xyz[invalid != 0] = np.nan
    return xyz
