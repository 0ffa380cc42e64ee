"""Benchmark: start-up cost of the command paths, a baseline commit against the current tree.

Usage::

    .venv/bin/python bench/bench_startup.py                       # baseline 7e868d2, 5 runs each
    .venv/bin/python bench/bench_startup.py --baseline HEAD~3 --runs 9
    .venv/bin/python bench/bench_startup.py --quick               # a smoke run: baseline HEAD, 3 cases, 1 run

The baseline is checked out with ``git worktree add`` into a temporary folder
(removed at the end). Each case runs in a fresh interpreter whose ``airmat``
and subpackages import from one tree (``airmat.calib`` from its ``calib/``
and so on, as its pyproject.toml's ``package-dir`` installs them: a finder put
first on ``sys.meta_path``, so that the editable install of the current tree
does not answer for the baseline), baseline and current alternating so that a
busy machine slows both alike. Both trees must have the one import root
``airmat`` (7e868d2 and later); the wall time is the median of ``--runs``
runs. The "loaded" column lists the heavy libraries left in ``sys.modules``.
A second table gives the largest third-party (not first-party, not standard-library) imports of each case by
cumulative ``-X importtime`` (one run, per top-level package). Prints
Markdown.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FIRST_PARTY = {"airmat"}
#: the heavy libraries and airmat's heavy stages, as listed in the "loaded" columns
HEAVY = ("numpy", "scipy", "matplotlib", "ezdxf", "cvxopt", "igl", "trimesh", "emcee", "open3d", "skimage",
         "dash", "plotly", "airmat.design", "airmat.inflation", "airmat.check")

_HELP = "import contextlib, io\nfrom airmat.cli import main\n" \
        "with contextlib.redirect_stdout(io.StringIO()):\n    try:\n        main(['--help'])\n" \
        "    except SystemExit:\n        pass\n"


def package_dirs(tree: Path) -> dict[str, str]:
    """``airmat`` and each subpackage -> its folder in ``tree`` (pyproject.toml's ``package-dir``)."""
    with open(tree / "pyproject.toml", "rb") as f:
        dirs = tomllib.load(f).get("tool", {}).get("setuptools", {}).get("package-dir", {})
    if "airmat" not in dirs:
        raise SystemExit(f"{tree}: no package-dir for 'airmat' in pyproject.toml: the tree predates the one "
                         "import root airmat (7e868d2); pick a later --baseline")
    return {name: str(tree / folder) for name, folder in dirs.items()}


def tree_finder(tree: Path) -> str:
    """Code that makes ``airmat`` and its subpackages import from ``tree`` (run before each case)."""
    return ("import sys\nfrom importlib.util import spec_from_file_location as _spec\n"
            f"_DIRS = {package_dirs(tree)!r}\n"
            "class _Tree:\n"
            "    @staticmethod\n"
            "    def find_spec(name, path=None, target=None):\n"
            "        d = _DIRS.get(name)\n"
            "        return None if d is None else _spec(name, d + '/__init__.py', submodule_search_locations=[d])\n"
            "sys.meta_path.insert(0, _Tree)\n")


def _open3d(tree: Path) -> str:
    """open3d with a ray-casting scene (the designer's closest points), as airmat imports it."""
    return "from airmat.lazy import import_open3d\nimport_open3d().t.geometry.RaycastingScene()\n"


def cases(tree: Path) -> list[tuple[str, str]]:
    """(label, code) of each measured start-up path in ``tree``."""
    parser = "from airmat.cli import build_parser\nbuild_parser()\n"
    return [
        ("python -c pass (interpreter only)", "pass"),
        ("`airmat --help`", _HELP),
        ("`import airmat.calib`", "import airmat.calib"),
        ("`import airmat.design`", "import airmat.design"),
        ("`import airmat.inflation.mesh`", "import airmat.inflation.mesh"),
        ("`airmat fit` imports", parser + "import airmat.cli.fit, airmat.calib.cylinder_fit, airmat.calib.scan_io"),
        ("`airmat calibrate` imports", parser + "import airmat.cli.calibrate, airmat.calib.calibrate, airmat.calib.plots, "
                                                "airmat.calib.calibration_io"),
        ("open3d for the closest points (`airmat design`, `refine`)", _open3d(tree)),
    ]


#: the cases of a --quick run
QUICK_CASES = ("python -c pass (interpreter only)", "`airmat --help`", "`import airmat.inflation.mesh`")


def _env(tree: Path) -> dict:
    return {**os.environ, "PYTHONPATH": str(tree)}


def wall_time(tree: Path, code: str) -> float:
    """Seconds for a fresh interpreter to run ``code`` with ``tree`` on the path."""
    code = tree_finder(tree) + code
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], env=_env(tree), cwd=tree, check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def loaded(tree: Path, code: str) -> list[str]:
    """The heavy packages in ``sys.modules`` after ``code`` (top level; airmat's by subpackage)."""
    probe = (tree_finder(tree) + code + "\nimport sys, json\n"
             "print(json.dumps(sorted({'.'.join(m.split('.')[:2 if m.startswith('airmat.') else 1]) "
             "for m in sys.modules})))")
    out = subprocess.run([sys.executable, "-c", probe], env=_env(tree), cwd=tree, check=True,
                         capture_output=True, text=True).stdout
    names = set(json.loads(out.strip().splitlines()[-1]))
    return [h for h in HEAVY if h in names]


def top_imports(tree: Path, code: str, k: int) -> list[tuple[str, float]]:
    """The ``k`` third-party top-level packages with the largest cumulative import time (ms).

    A package's time is its largest cumulative entry (the first import of any of its modules).
    """
    err = subprocess.run([sys.executable, "-X", "importtime", "-c", tree_finder(tree) + code], env=_env(tree), cwd=tree,
                         check=True, capture_output=True, text=True).stderr
    best: dict[str, float] = {}
    for line in err.splitlines():
        m = re.match(r"import time:\s+(\d+) \|\s+(\d+) \|(\s*)(\S+)", line)
        if not m:
            continue
        top = m.group(4).split(".")[0]
        if top in FIRST_PARTY or top in sys.stdlib_module_names or top.startswith("_"):
            continue
        best[top] = max(best.get(top, 0.0), int(m.group(2)) / 1e3)
    return sorted(((n, ms) for n, ms in best.items() if ms >= 1.0), key=lambda kv: -kv[1])[:k]  # 0 ms: probes


def checkout(commit: str, where: Path) -> Path:
    """``git worktree add --detach`` of ``commit`` into ``where``."""
    subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(where), commit], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return where


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", default="7e868d2",
                    help="commit to compare with, with the one import root airmat (default 7e868d2)")
    ap.add_argument("--runs", type=int, default=5, help="runs per case and tree (default 5)")
    ap.add_argument("--top", type=int, default=5, help="largest imports listed per case (default 5)")
    ap.add_argument("--quick", action="store_true",
                    help="a smoke run: baseline HEAD, three of the cases, one run each, top 3")
    args = ap.parse_args(argv)
    if args.quick:
        args.baseline, args.runs, args.top = "HEAD", 1, 3
    with tempfile.TemporaryDirectory(prefix="airmat-startup-") as tmp:
        base = checkout(args.baseline, Path(tmp) / "baseline")
        try:
            trees = {"baseline": base, "current": ROOT}
            labelled = {name: cases(tree) for name, tree in trees.items()}
            if args.quick:                               # the interpreter, `airmat --help`, the simulator
                labelled = {name: [c for c in rows if c[0] in QUICK_CASES] for name, rows in labelled.items()}
            rows = []
            for i in range(len(labelled["current"])):
                times = {name: [] for name in trees}
                for _ in range(args.runs):
                    for name, tree in trees.items():     # alternate: load on the machine hits both
                        times[name].append(wall_time(tree, labelled[name][i][1]))
                med = {name: statistics.median(t) for name, t in times.items()}
                rows.append((i, med, {name: loaded(tree, labelled[name][i][1]) for name, tree in trees.items()}))
            head = (f"| path | {args.baseline} (s) | current (s) | speed-up | loaded at {args.baseline} | "
                    "loaded now |")
            print(f"Start-up, median of {args.runs} fresh interpreters ({sys.executable}, "
                  f"{os.cpu_count()} CPUs)\n")
            print(head)
            print("|" + " --- |" * 6)
            for i, med, heavy in rows:
                label = labelled["current"][i][0]
                if labelled["baseline"][i][0] != label:
                    label = f"{labelled['baseline'][i][0]} → {label}"
                print(f"| {label} | {med['baseline']:.2f} | {med['current']:.2f} | "
                      f"{med['baseline'] / med['current']:.1f}x | {', '.join(heavy['baseline']) or '-'} | "
                      f"{', '.join(heavy['current']) or '-'} |")
            print("\nLargest third-party imports (cumulative `-X importtime`, ms, one run)\n")
            print(f"| path | {args.baseline} | current |")
            print("| --- | --- | --- |")
            for i in range(1, len(labelled["current"])):
                cells = [", ".join(f"{n} {ms:.0f}" for n, ms in top_imports(tree, labelled[name][i][1], args.top))
                         or "-" for name, tree in trees.items()]
                print(f"| {labelled['current'][i][0]} | {cells[0]} | {cells[1]} |")
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(base)], check=False,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return 0


if __name__ == "__main__":
    sys.exit(main())
