"""Benchmark: registering 1M-point scans of the built mattress (any frame, m or mm, floor, clutter) onto its shape.

Usage::

    .venv/bin/python bench/bench_registration.py [--points 1000000] [--seeds 0,1,2]
    .venv/bin/python bench/bench_registration.py --quick      # a smoke run: 50,000 points, one scan

Each scan is sampled on an analytic top face of 800 x 700 mm (a vault of radius
1 m, a saddle of κ = ±1/1.2 m, an elliptic cap) whose (+x, -y) corner is cut
by a straight edge (so that no symmetry maps the outline onto itself), with
0.5 mm noise, two holes of 80 mm, the mattress's sides down to a floor of
1.8 x 1.6 m, two boxes and 1 % stray points; it is then turned by a random
rotation, moved by up to 3 m and, every other seed, written in metres (read
as millimetres: 1000 times too small). The reference is the analytic face's
mesh at 10 mm. A row gives the time of ``airmat.asbuilt.registration.register``
and the RMS distance of the recovered top-face points from their true
positions; "success" is that RMS below 1 mm (the issue's criterion).
"""

from __future__ import annotations

import argparse
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from airmat.asbuilt.registration import register  # noqa: E402
from airmat.errors import InputError  # noqa: E402

W, H, H_MESH, CUT, NOISE = 0.8, 0.7, 0.01, 0.55, 0.5e-3
SHAPES = {
    "cylinder": lambda x, y: np.sqrt(1.0 - x ** 2) - 1.0,
    "saddle": lambda x, y: (x ** 2 - y ** 2) / 2.4,
    "dome": lambda x, y: -(x ** 2 + 0.7 * y ** 2) / 3.0,
}


def inside(x, y):
    """The outline: the rectangle without its corner beyond x - y = CUT (along the mesh's diagonals)."""
    return (np.abs(x) <= W / 2) & (np.abs(y) <= H / 2) & (x - y <= CUT + 1e-9)


def mesh(shape):
    nx, ny = round(W / H_MESH) + 1, round(H / H_MESH) + 1
    x, y = (a.ravel() for a in np.meshgrid(np.linspace(-W / 2, W / 2, nx), np.linspace(-H / 2, H / 2, ny),
                                           indexing="ij"))
    v = np.column_stack([x, y, SHAPES[shape](x, y)])
    i, j = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), indexing="ij")
    a = (i * ny + j).ravel()
    f = np.vstack([np.column_stack([a, a + ny, a + ny + 1]), np.column_stack([a, a + ny + 1, a + 1])])
    c = v[f].mean(axis=1)
    return v, f[inside(c[:, 0], c[:, 1])]


def scan(shape, n, seed):
    """(points (m), mask of the top face's points), in the reference's frame."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform([-W / 2, -H / 2], [W / 2, H / 2], (int(0.75 * n), 2))
    keep = inside(*xy.T)
    for centre in rng.uniform([-0.3, -0.25], [0.3, 0.25], (2, 2)):
        keep &= np.linalg.norm(xy - centre, axis=1) > 0.08
    xy = xy[keep]
    top = np.column_stack([xy, SHAPES[shape](*xy.T) + rng.normal(0, NOISE, len(xy))])
    z0 = top[:, 2].min() - 0.12
    t, side = rng.uniform(-1, 1, n // 12), rng.integers(4, size=n // 12)
    sx = np.where(side < 2, t * W / 2, np.where(side == 2, -W / 2, W / 2))
    sy = np.where(side < 2, np.where(side == 0, -H / 2, H / 2), t * H / 2)
    ok = inside(sx, sy)
    sides = np.column_stack([sx[ok], sy[ok], rng.uniform(z0, SHAPES[shape](sx[ok], sy[ok]))])
    fl = rng.uniform([-0.9, -0.8], [0.9, 0.8], (n // 6, 2))
    fl = fl[~inside(*fl.T)]
    parts = [top, sides, np.column_stack([fl, z0 + rng.normal(0, NOISE, len(fl))])]
    for lo, size in (((0.5, -0.3), (0.2, 0.15, 0.25)), ((-0.75, 0.45), (0.1, 0.25, 0.4))):
        box = rng.uniform(0, 1, (n // 40, 3)) * size
        face = rng.integers(3, size=len(box))
        box[np.arange(len(box)), face] = np.where(face == 2, size[2], np.where(
            rng.random(len(box)) < 0.5, 0.0, np.array(size)[face]))
        parts.append(box + [lo[0], lo[1], z0])
    parts.append(rng.uniform([-0.9, -0.8, z0], [0.9, 0.8, z0 + 0.5], (n // 100, 3)))
    pts = np.vstack(parts)
    mask = np.zeros(len(pts), dtype=bool)
    mask[:len(top)] = True
    return pts, mask


def commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE, capture_output=True,
                              text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "-"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=1_000_000)
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--shapes", default="cylinder,saddle,dome")
    ap.add_argument("--machine", default=platform.processor() or platform.machine())
    ap.add_argument("--quick", action="store_true", help="50,000 points, the saddle, one seed")
    args = ap.parse_args(argv)
    n, seeds, shapes = args.points, [int(s) for s in args.seeds.split(",")], args.shapes.split(",")
    if args.quick:
        n, seeds, shapes = 50_000, [1], ["saddle"]
    print(f"| shape | seed | scan points | unit | seconds | RMS error of recovered positions (mm) | inlier share "
          "| coverage | success | commit | machine |")
    print("|---|---:|---:|---|---:|---:|---:|---:|---|---|---|")
    for shape in shapes:
        v, f = mesh(shape)
        for seed in seeds:
            pts, top = scan(shape, n, seed)
            rot = Rotation.random(random_state=seed).as_matrix()
            moved = pts @ rot.T + np.random.default_rng(seed + 1000).uniform(-3, 3, 3)
            metres = seed % 2 == 1
            if metres:
                moved = moved / 1000
            t0 = time.perf_counter()
            try:
                reg = register(moved, v, f, seed=seed)
            except InputError as err:
                print(f"| {shape} | {seed} | {len(pts):,} | {'m' if metres else 'mm'} | {time.perf_counter() - t0:.2f} "
                      f"| - | - | - | refused: {err.one_line()[:60]} | `{commit()}` | {args.machine} |")
                continue
            dt = time.perf_counter() - t0
            err_mm = 1e3 * np.sqrt(np.mean(np.sum((reg.apply(moved[top]) - pts[top]) ** 2, axis=1)))
            print(f"| {shape} | {seed} | {len(pts):,} | {'m' if metres else 'mm'} | {dt:.2f} | {err_mm:.3f} "
                  f"| {reg.inlier_share:.3f} | {reg.coverage:.3f} | {'yes' if err_mm < 1 else 'NO'} "
                  f"| `{commit()}` | {args.machine} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
