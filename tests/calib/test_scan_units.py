"""Scan files in the unit other software writes them in: LAS in US survey feet from its CRS, SketchUp's
inches, a PLY's unit comment, a unit column in the manifest, and the calibration naming the unit of a file
it cannot place.

Every file is written by the library real software uses for it (laspy, trimesh, numpy's text writer), small,
and generated here from a seeded synthetic specimen.
"""

import numpy as np
import pytest

from airmat.constants import PAPER_D, PAPER_DELTA, PAPER_L
from airmat.errors import InputError
from airmat.calib.cylinder_fit import fit_cylinder
from airmat.calib.cylinder_stability import fit_cylinder_stable
from airmat.calib.model import kappa1
from airmat.calib.scan_io import read_scan
from airmat.synthetic.scan_write import write_scan
from airmat.synthetic.specimen_scan import specimen_scan
from airmat.units import SCAN_UNITS

R = 0.150                  #: radius of the specimen (m)
US_FT = 1200 / 3937        #: metres per US survey foot


@pytest.fixture(scope="module")
def spec():
    return specimen_scan(1 / R, n_points=30_000, seed=5)


def _fit(scan, **kw):
    return fit_cylinder_stable(scan.points, seed=0, quantization=scan.quantization, strict=True, **kw)


def _nn(a, b):
    from scipy.spatial import cKDTree

    return float(cKDTree(b).query(a)[0].max())


# ---------------------------------------------------------------------------------------------- units

_WKT_FTUS = ('PROJCS["NAD83 / New York Long Island (ftUS)",GEOGCS["NAD83",DATUM["North_American_Datum_1983",'
             'SPHEROID["GRS 1980",6378137,298.257222101]],PRIMEM["Greenwich",0],'
             'UNIT["degree",0.0174532925199433]],PROJECTION["Lambert_Conformal_Conic_2SP"],'
             'PARAMETER["standard_parallel_1",41.0333333333333],PARAMETER["standard_parallel_2",40.6666666666667],'
             'PARAMETER["latitude_of_origin",40.1666666666667],PARAMETER["central_meridian",-74],'
             'PARAMETER["false_easting",984250],PARAMETER["false_northing",0],'
             'UNIT["US survey foot",0.304800609601219,AUTHORITY["EPSG","9003"]],AXIS["Easting",EAST],'
             'AXIS["Northing",NORTH],AUTHORITY["EPSG","2263"]]')


def _las_in_feet(path, pts_m, *, crs):
    """A LAS 1.4 (point format 6) in US survey feet, its CRS in a WKT VLR or in GeoTIFF keys."""
    import laspy
    from laspy.vlrs.known import GeoKeyDirectoryVlr, GeoKeyEntryStruct, WktCoordinateSystemVlr

    ft = pts_m / US_FT + [984_000.0, 200_000.0, 30.0]     # state-plane feet
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.offsets = np.floor(ft.min(axis=0))
    header.scales = np.array([1e-4, 1e-4, 1e-4])
    if crs == "wkt":
        header.global_encoding.wkt = True
        header.vlrs.append(WktCoordinateSystemVlr(_WKT_FTUS))
    elif crs == "geotiff":
        vlr = GeoKeyDirectoryVlr()
        vlr.geo_keys_header.key_directory_version = 1
        vlr.geo_keys_header.key_revision = 1
        vlr.geo_keys_header.number_of_keys = 2
        keys = []
        for key, value in ((1024, 1), (3076, 9003)):     # model type projected; ProjLinearUnits = US survey foot
            entry = GeoKeyEntryStruct()
            entry.id, entry.tiff_tag_location, entry.count, entry.value_offset = key, 0, 1, value
            keys.append(entry)
        vlr.geo_keys = keys
        header.vlrs.append(vlr)
    las = laspy.LasData(header)
    las.x, las.y, las.z = ft[:, 0], ft[:, 1], ft[:, 2]
    las.write(str(path))
    return path


@pytest.mark.parametrize("crs", ["wkt", "geotiff"])
def test_las_in_us_survey_feet_is_read_in_feet_from_its_crs(tmp_path, spec, crs):
    path = _las_in_feet(tmp_path / f"survey_{crs}.las", spec.points, crs=crs)
    scan = read_scan(path)
    assert scan.units == "us-ft"
    assert _nn(scan.points + scan.offset - (np.array([984_000.0, 200_000.0, 30.0]) * US_FT), spec.points) < 1e-4
    assert _fit(scan).radius == pytest.approx(R, rel=0.005)


def test_scan_units_ft_and_in_are_accepted(tmp_path, spec):
    assert SCAN_UNITS["ft"] == 0.3048 and SCAN_UNITS["in"] == 0.0254
    for unit in ("ft", "in"):
        path = write_scan(tmp_path / f"{unit}.xyz", spec.points / SCAN_UNITS[unit], "xyz")   # columns in that unit
        scan = read_scan(path, units=unit)
        assert scan.units == unit
        np.testing.assert_allclose(scan.points + scan.offset, spec.points, atol=1e-4 * SCAN_UNITS[unit])


def _arc_mesh(radius, width, n_arc=160, n_width=40, arc_deg=100.0):
    """A triangulated strip of a cylinder of ``radius`` (in any unit), axis y."""
    phi = np.radians(np.linspace(-arc_deg / 2, arc_deg / 2, n_arc))
    y = np.linspace(-width / 2, width / 2, n_width)
    P, Y = np.meshgrid(phi, y, indexing="ij")
    v = np.column_stack([radius * np.sin(P).ravel(), Y.ravel(), radius * np.cos(P).ravel()])
    i, j = np.meshgrid(np.arange(n_arc - 1), np.arange(n_width - 1), indexing="ij")
    a = (i * n_width + j).ravel()
    f = np.concatenate([np.column_stack([a, a + n_width, a + 1]), np.column_stack([a + 1, a + n_width, a + n_width + 1])])
    return v, f


def test_sketchup_obj_in_inches_is_read_in_inches(tmp_path):
    import trimesh

    v, f = _arc_mesh(R / 0.0254, 0.4 / 0.0254)          # inches, as SketchUp models
    text = trimesh.Trimesh(v, f, process=False).export(file_type="obj", include_normals=False)
    path = tmp_path / "specimen_sketchup.obj"
    path.write_text("# Alias OBJ Model File\n# Exported from SketchUp, (c) 2000-2012 Trimble Navigation Limited\n"
                    "# File units = inches\n" + text)
    scan = read_scan(path)
    assert scan.units == "in"
    assert fit_cylinder(scan.points, seed=0, strict=True).radius == pytest.approx(R, rel=0.002)


@pytest.mark.parametrize("comment, unit", [("comment Units: cm", "cm"), ("comment units centimeters", "cm"),
                                           ("comment units inches", "in")])
def test_ply_with_a_units_comment_is_read_in_that_unit(tmp_path, spec, comment, unit):
    import trimesh

    pts = spec.points / SCAN_UNITS[unit]
    data = trimesh.PointCloud(pts).export(file_type="ply", encoding="binary")
    data = data.replace(b"\nelement vertex", f"\n{comment}\nelement vertex".encode(), 1)
    path = tmp_path / "specimen.ply"
    path.write_bytes(data)
    scan = read_scan(path)
    assert scan.units == unit
    np.testing.assert_allclose(scan.points + scan.offset, spec.points, atol=1e-9)


def _manifest(folder, rows, header="scan,l_mm,L_mm"):
    text = header + "\n" + "".join(",".join(str(c) for c in row) + "\n" for row in rows)
    (folder / "manifest.csv").write_text(text)
    return folder / "manifest.csv"


def _l_for_radius(radius, L=PAPER_L):
    """The string length that Equation 3 maps to ``radius`` with the paper's Delta and d (mm)."""
    from scipy.optimize import brentq

    return 1e3 * brentq(lambda l: kappa1(l, L, PAPER_DELTA, PAPER_D) - 1 / radius, 1e-4, L - 2 * PAPER_DELTA - 1e-6)


def _specimen_files(folder, radii, fmt="ply", factor=1e3, seed=0):
    import trimesh

    names = []
    for k, r in enumerate(radii):
        s = specimen_scan(1 / r, n_points=20_000, seed=seed + k)
        name = f"s{k}.{fmt}"
        if fmt == "ply":
            trimesh.PointCloud(s.points * factor).export(str(folder / name), file_type="ply", encoding="binary")
        else:
            write_scan(folder / name, s.points * factor, fmt)
        names.append(name)
    return names


def test_ply_in_centimetres_without_a_flag_is_refused_by_the_calibration_naming_cm(tmp_path):
    from airmat.calib.calibrate import fit_specimens
    from airmat.calib.manifest import read_manifest

    radii = [0.15, 0.2, 0.3]
    names = _specimen_files(tmp_path, radii)
    bad = specimen_scan(1 / 0.15, n_points=20_000, seed=9)
    import trimesh
    trimesh.PointCloud(bad.points * 100).export(str(tmp_path / names[0]), file_type="ply", encoding="binary")  # cm
    manifest = read_manifest(_manifest(tmp_path, [(n, f"{_l_for_radius(r):.1f}", 300) for n, r in zip(names, radii)]))
    with pytest.raises(InputError) as exc:
        fit_specimens(manifest, seed=0)
    line = exc.value.one_line()
    assert names[0] in line and "below the mattress" in line and "cm" in line, line


def test_las_in_feet_without_a_crs_is_refused_by_the_calibration_naming_ft(tmp_path):
    from airmat.calib.calibrate import fit_specimens
    from airmat.calib.manifest import read_manifest

    radii = [0.15, 0.2, 0.3]
    names = _specimen_files(tmp_path, radii, fmt="las", factor=1e3 / 0.3048)   # feet, written as if metres
    manifest = read_manifest(_manifest(tmp_path, [(n, f"{_l_for_radius(r):.1f}", 300) for n, r in zip(names, radii)]))
    with pytest.raises(InputError) as exc:
        fit_specimens(manifest, seed=0)
    line = exc.value.one_line()
    assert "Equation 3" in line and "--scan-units ft" in line, line


def test_manifest_units_column_lets_metres_and_millimetres_mix(tmp_path):
    from airmat.calib.calibrate import fit_specimens
    from airmat.calib.manifest import read_manifest

    radii = [0.15, 0.2, 0.3]
    names = _specimen_files(tmp_path, radii[:2])
    names += _specimen_files(tmp_path, radii[2:], fmt="pts", factor=1.0, seed=2)  # metres
    (tmp_path / "s0.pts").rename(tmp_path / "s2.pts")
    names[2] = "s2.pts"
    rows = [(n, f"{_l_for_radius(r):.1f}", 300, u) for n, r, u in zip(names, radii, ["", "mm", "m"])]
    manifest = read_manifest(_manifest(tmp_path, rows, header="scan,l_mm,L_mm,units"))
    assert manifest.units == (None, "mm", "m")
    specimens, _ = fit_specimens(manifest, seed=0)
    np.testing.assert_allclose([s.radius for s in specimens], radii, rtol=0.01)


def test_manifest_unknown_unit_is_refused_with_its_line(tmp_path):
    from airmat.calib.manifest import read_manifest

    for k in range(3):
        (tmp_path / f"s{k}.ply").write_bytes(b"ply\n")
    path = _manifest(tmp_path, [(f"s{k}.ply", 100, 300, "furlong" if k == 1 else "mm") for k in range(3)],
                     header="scan,l_mm,L_mm,units")
    with pytest.raises(InputError, match=r"line 3: units = 'furlong'.*m, cm, mm, in, ft"):
        read_manifest(path)
