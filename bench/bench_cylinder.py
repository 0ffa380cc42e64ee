"""Benchmark: airmat's robust cylinder fit against peers and a plain recipe, on the same scans.

Every method sees the same synthetic specimen scans (airmat.synthetic.specimen_scan:
partial arc, floor plane, 5% clutter, holes, string-end grooves, random pose) and
is timed on them; the table gives wall time and radius error per scan size.

- ``airmat``: airmat.calib.cylinder_fit.fit_cylinder on every point.
- ``recipe``: the plain recipe (bench/recipe_cylinder.py): open3d voxel downsampling and
  plane removal, open3d normals, axis = smallest eigenvector of the normals' scatter,
  circle by RANSAC in the projection (skimage), then scipy least_squares (soft_l1, scale
  from the MAD of the start's residuals) over axis, centre and radius on the points near
  that circle.
- ``pyransac3d``: pyransac3d.Cylinder().fit(points, thresh, maxIteration). Very slow
  (about 50 s at 100k points with its default budget): it gets a random subset of
  ``--ransac-points`` points and ``--ransac-iterations`` iterations, stated in the table.
- ``cylinder_fitting``: cylinder_fitting.fit(points) (Eberly's method, optimizing over
  axis directions in Python): it gets a random subset of ``--cf-points`` points.

With ``--formats N``: an N-point scan written in every scanner format by the
library real software uses (airmat.synthetic.scan_write: pye57, laspy+lazrs
(LAS 1.2 point format 3 and LAS 1.4 point format 6), open3d, trimesh, numpy
text layouts), read back with airmat.calib.scan_io.read_scan
(median of 9 reads, after one warm-up read that loads the library, each
followed by a read of the PLY file), and fitted: read time and CPU time, their
ratios to the PLY reads next to them, file size and radius error; then the
slow formats' libraries decoding alone (their floor).

With ``--process N``: ``airmat fit`` and the recipe as a script
(bench/recipe_cylinder.py, reading the file with open3d) run as whole
processes on an N-point binary PLY, alternately, start-up included (and the
script's imports + read alone, the floor of any such script): the
ratios of their median wall times (goal: airmat <= 0.85 x the script, and
the floor is the honest comparison while the plain recipe fails on this scan).

Run:  .venv/bin/python bench/bench_cylinder.py --sizes 100000,1000000 --repeats 3
Process:  .venv/bin/python bench/bench_cylinder.py --sizes 0 --process 1280000
Formats:  .venv/bin/python bench/bench_cylinder.py --sizes 0 --formats 1000000
Quick check:  .venv/bin/python bench/bench_cylinder.py --sizes 20000 --repeats 1 --cf-points 200
Smoke run:  .venv/bin/python bench/bench_cylinder.py --quick   (20,000 points, one scan, small peer budgets;
            a peer that is not installed is skipped with a note: pip install -e ".[bench]")
Targets (airmat): 1,000,000 points under 1.5 s with radius error < 0.1 %; 100k well under 1 s.
"""

from __future__ import annotations

import argparse
import importlib.util
import logging
import os
import sys
import time
import warnings

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from airmat.calib.cylinder_fit import fit_cylinder  # noqa: E402
from airmat.synthetic.specimen_scan import specimen_scan  # noqa: E402
from bench.recipe_cylinder import recipe_fit  # noqa: E402


def pyransac3d_fit(points, thresh, iterations):
    import pyransac3d

    return float(pyransac3d.Cylinder().fit(points, thresh=thresh, maxIteration=iterations).radius)


def cylinder_fitting_fit(points):
    import cylinder_fitting

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # its optimizer warns on some starts
        return float(cylinder_fitting.fit(points)[2])


def _timed(fn, *args, **kw):
    t0 = time.perf_counter()
    try:
        return fn(*args, **kw), time.perf_counter() - t0, ""
    except Exception as err:  # a peer failing is a result, not a crash of the benchmark
        return np.nan, time.perf_counter() - t0, f"{type(err).__name__}: {err}"[:60]


#: the peer libraries (the ``bench`` extra of pyproject.toml)
PEERS = ("pyransac3d", "cylinder_fitting")


def run(sizes, repeats, seed, kappa, arc_deg, ransac_points, ransac_iterations, cf_points, peers=PEERS):
    """Rows of the peer table; ``peers``: the names of PEERS to run beside airmat and the recipe."""
    rows = []
    for n in sizes:
        stats = {}
        for r in range(repeats):
            scan = specimen_scan(kappa, n_points=n, arc_deg=arc_deg, seed=seed + r)
            rng = np.random.default_rng(seed + 1000 + r)
            R = scan.radius
            runs = [("airmat", n, "-", lambda: fit_cylinder(scan.points, seed=seed).radius),
                    ("recipe", n, "-", lambda: recipe_fit(scan.points, seed=seed))]
            if "pyransac3d" in peers:
                m = min(n, ransac_points)
                sub = scan.points[rng.choice(n, m, replace=False)]
                runs.append(("pyransac3d", m, str(ransac_iterations),
                             lambda: pyransac3d_fit(sub, 3 * scan.noise, ransac_iterations)))
            if "cylinder_fitting" in peers:
                k = min(n, cf_points)
                sub2 = scan.points[rng.choice(n, k, replace=False)]
                runs.append(("cylinder_fitting", k, "-", lambda: cylinder_fitting_fit(sub2)))
            if r == 0 and not stats:  # warm-up: imports and first calls are not timed
                small = specimen_scan(kappa, n_points=5000, arc_deg=arc_deg, seed=seed + 999)
                fit_cylinder(small.points)
                recipe_fit(small.points)
            for name, used, iters, fn in runs:
                radius, dt, note = _timed(fn)
                s = stats.setdefault(name, dict(used=used, iters=iters, t=[], err=[], notes=set()))
                s["t"].append(dt)
                s["err"].append(abs(radius - R) / R * 100 if np.isfinite(radius) else np.nan)
                if note:
                    s["notes"].add(note)
        for name, s in stats.items():
            rows.append((n, name, s["used"], s["iters"], float(np.median(s["t"])), float(np.max(s["t"])),
                         float(np.nanmedian(s["err"])) if np.isfinite(s["err"]).any() else np.nan,
                         float(np.nanmax(s["err"])) if np.isfinite(s["err"]).any() else np.nan,
                         "; ".join(sorted(s["notes"]))))
    return rows


def format_rows(n, seed, kappa, arc_deg, n_reads=9):
    """[(format, library, read s, read / PLY read, CPU s, CPU / PLY CPU, MB, radius error %)] for an
    n-point scan.

    Each format's reads alternate with reads of the PLY file, and its ratios
    are the medians over the reads of read / the PLY read right after it: on
    a shared machine the load changes between formats, and even between
    rounds, less between neighbouring reads. CPU is this process's CPU time
    (all threads): multi-threaded readers pay it on every core they use, and
    it moves little with other jobs' load.
    """
    import tempfile
    from pathlib import Path

    from airmat.calib.scan_io import read_scan
    from airmat.synthetic.scan_write import FORMATS, write_scan

    try:
        import lzf  # noqa: F401  (python-lzf, the optional ``fast`` extra)
        lzf_reader = "python-lzf"
    except ImportError:
        lzf_reader = "open3d (no python-lzf)"
    library = {"e57": "pye57 (libE57, x/y/z only)", "las": "laspy", "laz": "laspy + lazrs (parallel)",
               "laz14": "laspy + lazrs (parallel, x/y/z layers)", "glb": "trimesh (scene graph)",
               "ply": "numpy (binary cloud)", "pts": "polars", "xyz": "polars", "txt": "polars",
               "pcd_ascii": "polars", "pcd_binary": "numpy", "pcd_compressed": lzf_reader}
    scan = specimen_scan(kappa, n_points=n, arc_deg=arc_deg, seed=seed)
    rows = []

    def timed(path):
        t0, c0 = time.perf_counter(), time.process_time()
        got = read_scan(path)
        return time.perf_counter() - t0, time.process_time() - c0, got

    with tempfile.TemporaryDirectory() as tmp:
        ply = write_scan(Path(tmp) / "scan_ply.ply", scan.points * 1e3, "ply", seed=seed)
        read_scan(ply)
        for fmt in ["ply", *sorted(f for f in FORMATS if f != "ply")]:
            path = ply if fmt == "ply" else \
                write_scan(Path(tmp) / f"scan_{fmt}{FORMATS[fmt]}", scan.points * 1e3, fmt, seed=seed)
            read_scan(path)  # warm-up: the library's import is start-up, not reading
            wall, cpu, r_wall, r_cpu = [], [], [], []
            for _ in range(n_reads):
                dt, dc, got = timed(path)
                dt_ply, dc_ply, _ = timed(ply)
                wall.append(dt)
                cpu.append(dc)
                r_wall.append(dt / dt_ply)
                r_cpu.append(dc / dc_ply)
            radius = fit_cylinder(got.points, seed=seed, quantization=got.quantization).radius
            rows.append((fmt, library.get(fmt, "open3d"), float(np.median(wall)), float(np.median(r_wall)),
                         float(np.median(cpu)), float(np.median(r_cpu)),
                         os.path.getsize(path) / 1e6, abs(radius - scan.radius) / scan.radius * 100))
    return rows


def decode_rows(n, seed, kappa, arc_deg, repeats=7):
    """[(step, CPU s, wall s)]: the libraries' own decoding of an n-point scan, alone (no ``read_scan``).

    The floor of each slow format's read, next to the whole ``read_scan`` of
    the PLY file: polars' CSV parse of the XYZ and PTS files, lazrs's LAZ
    decompression (format 3; format 6 with every layer and with the x/y/z
    layers), libE57's decode of x/y/z, python-lzf's decompression of a
    compressed PCD (when installed). Medians of ``repeats`` after a warm-up.
    """
    import tempfile
    from pathlib import Path

    import laspy
    import polars as pl
    import pye57

    from airmat.calib.scan_io import read_scan
    from airmat.calib.scan_readers import e57_reader, pcd_reader
    from airmat.synthetic.scan_write import write_scan

    scan = specimen_scan(kappa, n_points=n, arc_deg=arc_deg, seed=seed)
    floats = lambda k: {f"f{i}": pl.Float64 for i in range(k)}  # noqa: E731
    xyz_layers = laspy.DecompressionSelection.xy_returns_channel() | laspy.DecompressionSelection.Z
    parallel = (laspy.LazBackend.LazrsParallel,)

    def e57_decode(path):
        e57 = pye57.E57(str(path))
        try:
            e57_reader._read_cartesian(e57, e57.get_header(0))
        finally:
            e57.close()

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        f = {fmt: write_scan(Path(tmp) / f"s_{fmt}{suffix}", scan.points * 1e3, fmt, seed=seed)
             for fmt, suffix in [("ply", ".ply"), ("xyz", ".xyz"), ("pts", ".pts"), ("laz", ".laz"),
                                 ("laz14", ".laz"), ("e57", ".e57"), ("pcd_compressed", ".pcd")]}
        steps = [
            ("read_scan of the PLY file (numpy read + checks)", lambda: read_scan(f["ply"])),
            ("polars.read_csv, XYZ", lambda: pl.read_csv(f["xyz"], has_header=False, separator=" ",
                                                        quote_char=None, schema=floats(3))),
            ("polars.read_csv, PTS (3 of 7 columns)", lambda: pl.read_csv(
                f["pts"], has_header=False, skip_lines=1, separator=" ", quote_char=None, schema=floats(7),
                columns=[0, 1, 2])),
            ("laspy.read, LAZ format 3 (lazrs parallel)", lambda: laspy.read(f["laz"], laz_backend=parallel)),
            ("laspy.read, LAZ format 6, every layer", lambda: laspy.read(f["laz14"], laz_backend=parallel)),
            ("laspy.read, LAZ format 6, x/y/z layers", lambda: laspy.read(
                f["laz14"], laz_backend=parallel, decompression_selection=xyz_layers)),
            ("libE57 decode of x/y/z", lambda: e57_decode(f["e57"])),
        ]
        header = pcd_reader._header(f["pcd_compressed"])
        if pcd_reader._read_compressed(f["pcd_compressed"], header) is not None:
            steps.append(("python-lzf + numpy columns, compressed PCD",
                          lambda: pcd_reader._read_compressed(f["pcd_compressed"], header)))
        for name, fn in steps:
            fn()
            wall, cpu = [], []
            for _ in range(repeats):
                t0, c0 = time.perf_counter(), time.process_time()
                fn()
                wall.append(time.perf_counter() - t0)
                cpu.append(time.process_time() - c0)
            rows.append((name, float(np.median(cpu)), float(np.median(wall))))
    return rows


def decode_markdown(rows, n, repeats=7):
    head = (f"The libraries' own decoding alone, {n:,}-point scan (median of {repeats}; CPU: all threads)\n\n"
            "| step | CPU (s) | wall (s) |\n|---|---:|---:|\n")
    return head + "".join(f"| {name} | {c:.3f} | {w:.3f} |\n" for name, c, w in rows)


def process_rows(n, seed, kappa, arc_deg, repeats=5):
    """Whole processes on an n-point binary PLY: ``airmat fit`` against the recipe as a script.

    Both read the file themselves (airmat: airmat.calib.scan_io; the recipe: open3d)
    and pay their own start-up (imports); they run alternately, ``repeats``
    times each, in this one benchmark run. Returns
    [(method, median s, min s, max s, radius error %)] and the ratios of airmat's median to the
    script's and to the floor's (the script's imports and read alone).
    """
    import json
    import subprocess
    import tempfile
    from pathlib import Path

    from airmat.synthetic.scan_write import write_scan

    root = Path(__file__).resolve().parent.parent
    scan = specimen_scan(kappa, n_points=n, arc_deg=arc_deg, seed=seed)
    env = dict(os.environ, PYTHONPATH=str(root) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    with tempfile.TemporaryDirectory() as tmp:
        path = write_scan(Path(tmp) / "scan.ply", scan.points * 1e3, "ply", seed=seed)
        commands = {"airmat fit": [sys.executable, "-m", "airmat", "fit", str(path), "--json"],
                    "open3d + least_squares script": [sys.executable, str(root / "bench" / "recipe_cylinder.py"),
                                                      str(path)],
                    # the floor of any such script: its imports and the open3d read, no fit at all
                    "script's imports + open3d read only": [
                        sys.executable, "-c", "import json, sys, numpy as np, open3d as o3d, scipy.optimize, "
                        "skimage.measure; from skimage.measure import CircleModel, ransac; "
                        "np.asarray(o3d.io.read_point_cloud(sys.argv[1]).points); "
                        "print(json.dumps({'radius_mm': float('nan')}))", str(path)]}
        times = {k: [] for k in commands}
        radius = {}
        for r in range(repeats + 1):  # the first round warms the file cache and is not timed
            for name, cmd in commands.items():
                t0 = time.perf_counter()
                out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True, cwd=tmp)
                if r:
                    times[name].append(time.perf_counter() - t0)
                radius[name] = json.loads(out.stdout)["radius_mm"] / 1e3
    rows = [(name, float(np.median(t)), float(np.min(t)), float(np.max(t)),
             abs(radius[name] - scan.radius) / scan.radius * 100) for name, t in times.items()]
    return rows, rows[0][1] / rows[1][1], rows[0][1] / rows[2][1]


def process_markdown(rows, ratio, floor_ratio, n, repeats):
    head = (f"Whole process on a {n:,}-point binary PLY (floor, clutter, grooves), {repeats} alternating "
            f"runs each; airmat / script = {ratio:.2f}, airmat / (script's imports + read) = {floor_ratio:.2f}\n\n"
            "| command | time median (s) | min (s) | max (s) | radius error (%) |\n"
            "|---|---:|---:|---:|---:|\n")
    return head + "".join(f"| {m} | {t:.2f} | {lo:.2f} | {hi:.2f} | {'-' if not np.isfinite(e) else f'{e:.4f}'} |\n"
                          for m, t, lo, hi, e in rows)


def format_markdown(rows, n, n_reads=9):
    head = (f"Read time per format, {n:,}-point scan (medians of {n_reads} reads after a warm-up, each "
            "followed by a PLY read: × PLY is the median of read / that PLY read; CPU: this process's, all "
            "threads; radius error of the fit of what was read)\n\n"
            "| format | library | read (s) | × PLY read | CPU (s) | × PLY CPU | file (MB) | radius error (%) |\n"
            "|---|---|---:|---:|---:|---:|---:|---:|\n")
    return head + "".join(f"| {f} | {lib} | {t:.3f} | {r:.2f} | {c:.3f} | {rc:.2f} | {mb:.1f} | {e:.4f} |\n"
                          for f, lib, t, r, c, rc, mb, e in rows)


def markdown(rows, repeats, kappa, arc_deg):
    head = (f"Scans: kappa = {kappa:g} 1/m (R = {1e3 / kappa:.0f} mm), {arc_deg:g} deg arc, floor, 5% clutter, "
            f"holes, 4 mm grooves, random pose; {repeats} scan(s) per size (median / worst).\n\n"
            "| scan points | method | points used | iterations | time median (s) | time max (s) "
            "| radius error median (%) | radius error max (%) | notes |\n"
            "|---:|---|---:|---:|---:|---:|---:|---:|---|\n")
    body = "".join(f"| {n:,} | {m} | {u:,} | {it} | {t:.3f} | {tm:.3f} | {e:.4f} | {em:.4f} | {note} |\n"
                   for n, m, u, it, t, tm, e, em, note in rows)
    return head + body


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", default="100000,1000000", help="comma-separated scan sizes (points)")
    p.add_argument("--repeats", type=int, default=3, help="scans per size (different seeds)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--kappa", type=float, default=5.0, help="curvature of the specimens (1/m)")
    p.add_argument("--arc-deg", type=float, default=90.0, help="visible arc (degrees)")
    p.add_argument("--ransac-points", type=int, default=10_000, help="subset given to pyransac3d")
    p.add_argument("--ransac-iterations", type=int, default=200, help="pyransac3d maxIteration")
    p.add_argument("--cf-points", type=int, default=500, help="subset given to cylinder_fitting")
    p.add_argument("--no-peers", action="store_true", help="only airmat and the recipe")
    p.add_argument("--formats", type=int, default=0, metavar="N",
                   help="also time reading an N-point scan in every scanner format (0: skip)")
    p.add_argument("--process", type=int, default=0, metavar="N",
                   help="also time `airmat fit` and the recipe script as whole processes on an N-point "
                        "binary PLY (0: skip)")
    p.add_argument("--process-repeats", type=int, default=5, help="runs of each process")
    p.add_argument("--quick", action="store_true",
                   help="a smoke run: one 20,000-point scan, small peer budgets, peers not installed skipped")
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    peers = () if args.no_peers else PEERS
    if args.quick:
        args.sizes, args.repeats, args.cf_points = "20000", 1, 200
        args.ransac_points, args.ransac_iterations = 2000, 20
        missing = [name for name in peers if importlib.util.find_spec(name) is None]
        for name in missing:
            print(f"note: {name} is not installed, skipped (pip install -e \".[bench]\")\n")
        peers = tuple(name for name in peers if name not in missing)
    sizes = [int(s) for s in args.sizes.split(",") if s.strip() and int(s) > 0]
    if sizes:
        rows = run(sizes, args.repeats, args.seed, args.kappa, args.arc_deg, args.ransac_points,
                   args.ransac_iterations, args.cf_points, peers)
        print(markdown(rows, args.repeats, args.kappa, args.arc_deg))
    if args.process:
        rows, ratio, floor_ratio = process_rows(args.process, args.seed, args.kappa, args.arc_deg,
                                                args.process_repeats)
        print(process_markdown(rows, ratio, floor_ratio, args.process, args.process_repeats))
    if args.formats:
        print(format_markdown(format_rows(args.formats, args.seed, args.kappa, args.arc_deg), args.formats))
        print(decode_markdown(decode_rows(args.formats, args.seed, args.kappa, args.arc_deg), args.formats))
    return 0


if __name__ == "__main__":
    sys.exit(main())
