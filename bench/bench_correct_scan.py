"""Benchmark: ``airmat correct`` on a million-point scan, this tree against a baseline commit, in one run.

Usage::

    .venv/bin/python bench/bench_correct_scan.py --baseline 7c840dd
    .venv/bin/python bench/bench_correct_scan.py --points 200000          # a smaller scan, this tree only
    .venv/bin/python bench/bench_correct_scan.py --quick                  # a smoke run: 50 000 points, this tree

The world of docs/guide/correct.md's example: vault1 designed with the paper's values (open loop,
``airmat design --preset vault1``), built at Δ = 22 mm, d = 75 mm with every string cut within ±3 mm
(``airmat synth-built --seed 7``), scanned with ``--points`` points (floor, clutter, 85 % of the face, a
random frame). Each tree runs ``airmat correct D B/scan.ply --out C`` in a fresh interpreter (the
baseline checked out with ``git worktree add`` into a temporary folder); the table gives the wall time,
the time over one inflation of the design from the flat mattress at 20 mm (``airmat inflate``'s median
run, measured here), the update's verdict and (Δ, d)'s 95 % intervals from ``correct.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

PY = sys.executable


def airmat(tree: Path, *args, cwd: Path) -> float:
    """Run ``airmat ARGS`` with ``airmat`` and its subpackages imported from ``tree`` (not the editable install's
    tree: ``bench_startup``'s finder); its wall time (s)."""
    from bench_startup import tree_finder

    code = tree_finder(tree) + f"import runpy\nsys.argv = ['airmat', *{list(args)!r}]\nrunpy.run_module('airmat', run_name='__main__')\n"
    env = {**os.environ, "PYTHONPATH": str(tree)}
    t = time.perf_counter()
    subprocess.run([PY, "-c", code], cwd=cwd, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t


def one_inflation(folder: Path) -> float:
    """Seconds of one inflation of the design at ``folder`` from the flat mattress at 20 mm (its median lengths)."""
    from airmat.check.inflation_check import check
    from airmat.design.design_io import read_design

    return check(read_design(folder), resolution=0.02, envelope=False).runs["median"].inflation.seconds


def summary(folder: Path) -> tuple:
    """(converged, message, Δ interval (mm), d interval (mm)) from ``correct.json``."""
    doc = json.loads((folder / "correct.json").read_text())
    upd = doc["update"]
    iv = {k: upd[k] for k in ("delta_95_mm", "d_95_mm")}
    return upd.get("converged"), upd.get("message", ""), iv


def commit(tree: Path) -> str:
    rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=tree, capture_output=True, text=True).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=tree, capture_output=True,
                           text=True).stdout.strip()
    return rev + (" + changes" if dirty else "")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", help="a commit to run beside this tree (git worktree)")
    ap.add_argument("--points", type=int, default=1_000_000, help="scan points (default 1 000 000)")
    ap.add_argument("--machine", default=platform.processor() or platform.machine(), help="the machine column")
    ap.add_argument("--quick", action="store_true", help="a smoke run: 50 000 points, no baseline")
    args = ap.parse_args(argv)
    if args.quick:
        args.points, args.baseline = 50_000, None
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        airmat(ROOT, "design", "--preset", "vault1", "--out", "D", cwd=tmp)
        airmat(ROOT, "synth-built", "D", "--out", "B", "--delta-mm", "22", "--thickness-mm", "75",
               "--cut-error-mm", "3", "--seed", "7", "--points", str(args.points), cwd=tmp)
        trees = [("this tree", ROOT)]
        if args.baseline:
            base = tmp / "baseline"
            subprocess.run(["git", "worktree", "add", "--detach", str(base), args.baseline], cwd=ROOT, check=True,
                           capture_output=True)
            trees.insert(0, (f"baseline {args.baseline}", base))
        one = one_inflation(tmp / "D")
        rows = []
        try:
            for label, tree in trees:
                out = f"C-{len(rows)}"
                seconds = airmat(tree, "correct", "D", "B/scan.ply", "--out", out, cwd=tmp)
                converged, message, iv = summary(tmp / out)
                rows.append((label, commit(tree), seconds, converged, message, iv))
        finally:
            if args.baseline:
                subprocess.run(["git", "worktree", "remove", "--force", str(tmp / "baseline")], cwd=ROOT,
                               capture_output=True)
        print("| tree | scan points | `airmat correct` (s) | one inflation (s) | ratio | converged | update | "
              "95 % intervals (mm) | commit | machine |")
        print("|---|---:|---:|---:|---:|---|---|---|---|---|")
        for label, rev, seconds, converged, message, iv in rows:
            ivs = "; ".join(f"{k} {v}" for k, v in iv.items())
            print(f"| {label} | {args.points:,} | {seconds:.1f} | {one:.1f} | {seconds / one:.0f}x | {converged} | "
                  f"{message} | {ivs} | `{rev}` | {args.machine} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
