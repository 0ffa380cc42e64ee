"""A campaign of scan files as other software writes them: the floor that dominates a lab scan, the precision
they store, the text layouts exporters use, one line on stderr, and an honest standard error of kappa (their
units: tests/calib/test_scan_units.py).

Every file is written by the library real software uses for it (laspy, pye57, trimesh, open3d, numpy's
text writer in an exporter's layout), small, and generated here from a seeded synthetic specimen.
"""

import subprocess
import sys

import numpy as np
import pytest

from airmat.errors import InputError
from airmat.calib.cylinder_fit import fit_cylinder
from airmat.calib.cylinder_stability import fit_cylinder_stable
from airmat.calib.scan_io import read_scan
from airmat.synthetic.scan_write import write_scan
from airmat.synthetic.specimen_scan import specimen_scan

R = 0.150                  #: radius of the campaign's specimen (m)


@pytest.fixture(scope="module")
def spec():
    return specimen_scan(1 / R, n_points=30_000, seed=5)


def _fit(scan, **kw):
    return fit_cylinder_stable(scan.points, seed=0, quantization=scan.quantization, strict=True, **kw)


# ------------------------------------------------------------------------------- floor-dominated lab scans

def _lab_scan(floor_fraction, wall, seed):
    """A specimen on a floor 3.8-4.5 m across (``floor_fraction`` of the points), with or without a wall."""
    from scipy.spatial.transform import Rotation

    s = specimen_scan(1 / R, n_points=60_000, floor_fraction=floor_fraction, floor_margin=1.3,
                      outlier_fraction=0.01, noise=0.0005, seed=seed, pose=False)
    pts = s.points
    rng = np.random.default_rng(seed)
    if wall:
        floor = pts[s.labels == 1]
        n = len(floor) // 3
        wall_pts = np.column_stack([np.full(n, floor[:, 0].max()), rng.uniform(floor[:, 1].min(), floor[:, 1].max(), n),
                                    floor[:, 2].min() + rng.uniform(0, 1.5, n)]) + rng.normal(0, 0.0005, (n, 3))
        pts = np.concatenate([pts, wall_pts])
    lo, hi = np.percentile(pts, [0.5, 99.5], axis=0)
    rot = Rotation.random(random_state=seed).as_matrix()
    return pts @ rot.T + rng.uniform(-1, 1, 3), float(np.linalg.norm(hi - lo))


@pytest.mark.parametrize("floor_fraction, wall", [(0.57, False), (0.85, False), (0.6, True), (0.8, True)])
def test_lab_scan_where_the_floor_dominates_fits(tmp_path, floor_fraction, wall):
    import trimesh

    pts, across = _lab_scan(floor_fraction, wall, seed=3)
    assert 3.8 < across < 4.6   # the campaign's lab scenes: 3.8-4.5 m across
    path = tmp_path / "lab.ply"
    trimesh.PointCloud(pts * 1e3).export(str(path), file_type="ply", encoding="binary")
    fit = _fit(read_scan(path))
    assert fit.radius == pytest.approx(R, rel=0.005)
    assert fit.noise == pytest.approx(0.0005, rel=0.3)   # the scanner's, not the room's


# -------------------------------------------------------------------------------------------- precision

def test_float32_ply_at_site_coordinates_fits_when_the_step_does_not_matter(tmp_path, spec):
    import trimesh

    site = np.array([2.5e6, 6.1e6, 3.0e4])         # mm: float32 steps of 0.5 mm there
    rng = np.random.default_rng(0)
    pts = specimen_scan(1 / R, n_points=30_000, noise=0.0003, seed=6).points * 1e3 + site
    path = tmp_path / "site_float32.ply"
    trimesh.PointCloud(pts.astype(np.float32)).export(str(path), file_type="ply", encoding="binary")
    assert b"property float x" in path.read_bytes()[:300]
    scan = read_scan(path)
    assert scan.quantization == pytest.approx(5e-4)      # m
    fit = _fit(scan)
    # the same float32 values as float64 far from nothing: the effect of the step is on the fit, not the step
    exact = fit_cylinder_stable(scan.points, seed=0, strict=True)
    assert fit.radius == pytest.approx(exact.radius, rel=1e-5)
    assert fit.radius == pytest.approx(R, rel=0.005)
    del rng


def test_float32_ply_whose_step_loses_the_surface_is_refused(tmp_path, spec):
    import trimesh

    path = tmp_path / "utm_float32.ply"
    trimesh.PointCloud(((spec.points + [5e5, 4.2e6, 0.0]) * 1e3).astype(np.float32)).export(
        str(path), file_type="ply", encoding="binary")
    scan = read_scan(path)
    with pytest.raises(InputError, match="lost precision: stored as 32-bit floats"):
        _fit(scan)


def test_float32_e57_far_from_the_origin_is_refused_in_one_line(tmp_path, spec):
    path = write_scan(tmp_path / "utm.e57", (spec.points + [5e5, 4.2e6, 100.0]) * 1e3, "e57")  # pye57: single floats
    with pytest.raises(InputError, match="lost precision: stored as 32-bit floats far from the origin, steps of "
                                         "500 mm"):
        read_scan(path)


def test_float32_e57_near_the_origin_fits(tmp_path, spec):
    path = write_scan(tmp_path / "site.e57", (spec.points + [3000.0, 2000.0, 50.0]) * 1e3, "e57")
    scan = read_scan(path)
    assert 0 < scan.quantization < 3e-4
    assert _fit(scan).radius == pytest.approx(R, rel=0.005)


def _las_scaled(path, pts_m, scale):
    import laspy

    header = laspy.LasHeader(point_format=6, version="1.4")
    header.offsets = np.floor(pts_m.min(axis=0))
    header.scales = np.array([scale] * 3)
    las = laspy.LasData(header)
    las.x, las.y, las.z = pts_m[:, 0], pts_m[:, 1], pts_m[:, 2]
    las.write(str(path))
    return path


def test_las_at_pdal_default_centimetre_scale_is_named(tmp_path, spec):
    scan = read_scan(_las_scaled(tmp_path / "pdal.las", spec.points, 0.01))
    assert scan.quantization == pytest.approx(0.01)
    try:
        fit = _fit(scan)
    except InputError as err:
        line = err.one_line()
        assert "scale 0.01" in line and "10 mm" in line, line
        assert "0.0018" not in line and "noise" not in line.split("scale")[0], line
    else:   # the step is rounding noise of sd step/sqrt(12): the error bar must cover the truth
        assert abs(fit.kappa - 1 / R) < 3 * fit.kappa_se
        assert fit.noise >= 0.01 / np.sqrt(12) * 0.9


def test_las_at_a_step_no_specimen_survives_is_refused_naming_the_scale(tmp_path, spec):
    with pytest.raises(InputError) as exc:
        read_scan(_las_scaled(tmp_path / "coarse.las", spec.points, 0.05))
    line = exc.value.one_line()
    assert "scale 0.05" in line and "50 mm" in line, line


# ------------------------------------------------------------------------------------------ text readers

def test_xyz_without_a_final_line_break_is_read(tmp_path, spec):
    path = tmp_path / "no_eol.xyz"
    np.savetxt(path, spec.points * 1e3, fmt="%.4f")
    path.write_bytes(path.read_bytes().rstrip(b"\n"))
    scan = read_scan(path)
    assert len(scan.points) == len(spec.points)


def test_xyz_cut_inside_its_last_number_is_still_refused(tmp_path, spec):
    path = tmp_path / "cut.xyz"
    np.savetxt(path, spec.points * 1e3, fmt="%.4f")
    path.write_bytes(path.read_bytes().rstrip(b"\n")[:-3])
    with pytest.raises(InputError, match="truncated XYZ"):
        read_scan(path)


def test_leica_pts_with_several_blocks_is_read_whole(tmp_path, spec):
    pts = spec.points * 1e3
    parts = np.array_split(pts, 3)
    path = tmp_path / "blocks.pts"
    with open(path, "w") as fh:
        for part in parts:
            fh.write(f"{len(part)}\n")
            np.savetxt(fh, np.column_stack([part, np.full(len(part), 7), np.full((len(part), 3), 200)]),
                       fmt=["%.4f"] * 3 + ["%d"] * 4)
    scan = read_scan(path)
    assert len(scan.points) == len(pts)
    np.testing.assert_allclose(scan.points + scan.offset, spec.points, atol=1e-7)


def test_leica_pts_whose_block_counts_disagree_is_refused(tmp_path, spec):
    pts = spec.points[:3000] * 1e3
    path = tmp_path / "bad_blocks.pts"
    with open(path, "w") as fh:
        fh.write("1500\n")
        np.savetxt(fh, pts[:1500], fmt="%.4f")
        fh.write("2000\n")
        np.savetxt(fh, pts[1500:], fmt="%.4f")
    with pytest.raises(InputError, match="block"):
        read_scan(path)


@pytest.mark.parametrize("header", ["ID,X,Y,Z,Intensity", "//id,x,y,z,intensity", "Index;X;Y;Z;I"])
def test_csv_with_an_id_column_reads_x_y_z_by_name(tmp_path, spec, header):
    sep = ";" if ";" in header else ","
    pts = spec.points * 1e3
    path = tmp_path / "with_id.txt"
    table = np.column_stack([np.arange(len(pts)), pts, np.full(len(pts), 3)])
    np.savetxt(path, table, fmt=["%d", "%.4f", "%.4f", "%.4f", "%d"], delimiter=sep, header=header, comments="")
    scan = read_scan(path)
    np.testing.assert_allclose(scan.points + scan.offset, spec.points, atol=1e-7)


def test_binary_ply_named_xyz_is_read_as_ply(tmp_path, spec):
    import trimesh

    path = tmp_path / "actually_ply.xyz"
    trimesh.PointCloud(spec.points * 1e3).export(str(path), file_type="ply", encoding="binary")
    scan = read_scan(path)
    np.testing.assert_allclose(scan.points + scan.offset, spec.points, atol=1e-9)


def test_semicolon_decimal_comma_export_is_read(tmp_path, spec):
    pts = spec.points * 1e3
    path = tmp_path / "excel.txt"
    text = "\n".join(";".join(f"{v:.4f}".replace(".", ",") for v in row) for row in pts) + "\n"
    path.write_text("X;Y;Z\n" + text)
    scan = read_scan(path)
    np.testing.assert_allclose(scan.points + scan.offset, spec.points, atol=1e-7)


# -------------------------------------------------------------------------------------- one line on stderr

def _cli(*argv):
    return subprocess.run([sys.executable, "-W", "default", "-m", "airmat", *argv], capture_output=True, text=True,
                          timeout=300)


def test_corrupted_binary_ply_gives_one_line(tmp_path, spec):
    import trimesh

    path = tmp_path / "corrupt.ply"
    trimesh.PointCloud(spec.points * 1e3).export(str(path), file_type="ply", encoding="binary")
    data = bytearray(path.read_bytes())
    body = data.index(b"end_header") + 11
    rng = np.random.default_rng(1)
    data[body + 100:] = rng.integers(0, 256, len(data) - body - 100, dtype=np.uint8).tobytes()   # scrambled body
    path.write_bytes(bytes(data))
    proc = _cli("fit", str(path))
    assert proc.returncode == 2, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert f"{path}: damaged file" in proc.stderr, proc.stderr


def test_float32_e57_far_away_gives_one_line_through_the_cli(tmp_path, spec):
    path = write_scan(tmp_path / "utm.e57", (spec.points + [5e5, 4.2e6, 100.0]) * 1e3, "e57")
    proc = _cli("fit", str(path))
    assert proc.returncode == 2, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "32-bit" in proc.stderr


# ------------------------------------------------------------------------------------ an honest error bar

def _rippled_scan(seed, *, ripple, noise, outliers=0.05):
    """A specimen scan whose face departs from the cylinder by a smooth random field of sd ``ripple`` (m;
    wavelengths 3-15 cm: a scanner's banding, the fabric's wrinkles) on top of white noise ``noise``: residuals
    correlated along the surface, as real scans' are."""
    from scipy.spatial.transform import Rotation

    s = specimen_scan(1 / R, n_points=60_000, noise=noise, outlier_fraction=outliers, seed=seed, pose=False)
    rng = np.random.default_rng(seed + 1000)
    pts, on = s.points.copy(), s.labels == 0
    x, y, z = pts[on].T
    arc = R * np.arctan2(x, z)
    k = 40
    lam, angle, phase = rng.uniform(0.03, 0.15, k), rng.uniform(0, 2 * np.pi, k), rng.uniform(0, 2 * np.pi, k)
    field = ripple * np.sqrt(2 / k) * np.cos(np.outer(arc, 2 * np.pi / lam * np.cos(angle))
                                              + np.outer(y, 2 * np.pi / lam * np.sin(angle)) + phase).sum(axis=1)
    normal = np.column_stack([x, np.zeros_like(x), z]) / np.hypot(x, z)[:, None]
    pts[on] += field[:, None] * normal
    return pts @ Rotation.random(random_state=seed).as_matrix().T, s.kappa


@pytest.mark.slow
@pytest.mark.parametrize("ripple, noise, n_seeds, most_se", [
    (0.0015, 0.003, 20, 0.01),      # heavy: 3 mm white noise, 1.5 mm ripples, 5 % outliers
    (0.00025, 0.0005, 10, 0.003),   # light: a good scanner on a taut face
    (0.0, 0.003, 10, 0.003),        # white noise only: the error bar must not inflate
])
def test_kappa_standard_error_covers_the_truth_over_seeds(ripple, noise, n_seeds, most_se):
    z, rel_se = [], []
    for seed in range(n_seeds):
        pts, kappa = _rippled_scan(seed, ripple=ripple, noise=noise)
        fit = fit_cylinder(pts, seed=0)
        z.append((fit.kappa - kappa) / fit.kappa_se)
        rel_se.append(fit.kappa_se / kappa)
    z = np.abs(z)
    # +-2 se holds 95 % of a normal error; 80 % leaves room for the draws
    assert np.mean(z < 2) >= 0.8, np.round(z, 2)
    # and it is not honest by being useless: a fraction of a percent of kappa
    assert np.median(rel_se) < most_se, np.round(rel_se, 4)
