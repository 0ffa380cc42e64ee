"""Dependencies point one way: no import cycles, the product does not import the test data, nor private names.

Every product module is named as an installed user imports it (``airmat.calib.model``): the stage folders
at the repository root install under the one import root ``airmat`` (pyproject's package-dir, ``FOLDERS``).
Imports are read from the source (:mod:`ast`), every ``import``/``from`` statement anywhere in a file,
inside functions too: a function-level import still makes the module depend on the other one.
"""

import ast
import functools
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

#: repository folder -> the package it installs as (pyproject.toml, [tool.setuptools] package-dir)
FOLDERS = {"airmat": "airmat", "calib": "airmat.calib", "design": "airmat.design", "inflation": "airmat.inflation",
           "check": "airmat.check", "report": "airmat.report", "data_synthetic": "airmat.synthetic",
           "asbuilt": "airmat.asbuilt"}

#: the product: every package but the synthetic data's
PRODUCT = tuple(f for f, pkg in FOLDERS.items() if pkg != "airmat.synthetic")

#: first parts of module names that do not exist: the folders imported as top-level packages
OLD_TOP_LEVEL = ("calib", "design", "inflation", "check", "report", "data_synthetic", "asbuilt")


def _module_names(root: Path, folders: dict) -> dict:
    """Module name -> file, of every ``.py`` file in the folders (a package's ``__init__`` named as the package)."""
    modules = {}
    for folder, package in folders.items():
        for path in sorted((root / folder).rglob("*.py")):
            parts = path.relative_to(root / folder).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            modules[".".join((package, *parts))] = path
    return modules


def _imports(path: Path, module: str | None = None, is_package: bool = False):
    """(lineno, imported module, [names]) of every import statement in a file, inside functions too.

    A relative import is resolved against ``module`` (the file's own module name; ``is_package``
    when the file is a package's ``__init__``); without it relative imports are skipped.
    ``from M import a, b`` yields M with its names: whether a name is a submodule of M is
    for the caller to tell.
    """
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield node.lineno, a.name, []
        elif isinstance(node, ast.ImportFrom):
            names = [a.name for a in node.names]
            if node.level == 0:
                yield node.lineno, node.module, names
            elif module is not None:
                base = module.split(".") if is_package else module.split(".")[:-1]
                base = base[:len(base) - (node.level - 1)]
                yield node.lineno, ".".join(base + ([node.module] if node.module else [])), names


def _files(*folders):
    return [p for f in folders for p in sorted((ROOT / f).rglob("*.py"))]


@functools.cache
def _product_modules() -> dict:
    return _module_names(ROOT, FOLDERS)


def _imported_modules(path: Path) -> list:
    """(module, names) of a file's imports, relative ones resolved by the file's place in ``FOLDERS``."""
    name = next((m for m, p in _product_modules().items() if p == path), None)
    return [(m, names) for _, m, names in _imports(path, name, path.name == "__init__.py")]


def _is_under(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


# --- import cycles ---------------------------------------------------------------------------------------------


def import_graph(modules: dict) -> dict:
    """Module -> {imported module: line of the first such import}, between the given modules only.

    ``from P import x`` is an edge to ``P.x`` when that is a module, else to ``P`` (x is one of its
    names). A package ``__init__`` whose names are attached lazily (``airmat.lazy.attach``) imports its
    submodules only when a name is used: no edge, unless it has an import statement of its own.
    Importing a module runs its parent packages' ``__init__`` first, as every submodule import does:
    those are not counted as edges (a parent importing its submodule would otherwise always close a cycle).
    """
    graph = {}
    for name, path in modules.items():
        edges = {}
        for line, target, names in _imports(path, name, path.name == "__init__.py"):
            found = [f"{target}.{n}" for n in names if f"{target}.{n}" in modules] if names else []
            if not found or len(found) < len(names):
                # the longest known module the statement names (import a.b.c: a.b.c, else a.b, ...)
                parts = target.split(".")
                known = next((".".join(parts[:k]) for k in range(len(parts), 0, -1)
                              if ".".join(parts[:k]) in modules), None)
                found += [known] if known else []
            for dep in found:
                if dep != name:
                    edges.setdefault(dep, line)
        graph[name] = edges
    return graph


def strongly_connected(graph: dict) -> list:
    """Tarjan's strongly connected components of more than one module, each sorted; sorted."""
    index, low, on_stack, stack, found = {}, {}, set(), [], []
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]          # iterative: no recursion limit
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            v, children = work[-1]
            w = next(children, None)
            if w is not None:
                if w not in graph:
                    continue
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                component = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    component.append(w)
                    if w == v:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return sorted(found)


def a_cycle(graph: dict, component: list) -> list:
    """One cycle through the component's first module, as the modules in import order (first one repeated)."""
    start, inside = component[0], set(component)
    parent, queue = {start: None}, [start]
    for v in queue:                                            # breadth first: the shortest cycle back to start
        for w in sorted(graph[v]):
            if w == start:
                path = [v]
                while parent[path[-1]] is not None:
                    path.append(parent[path[-1]])
                return [start, *reversed(path[:-1]), start]
            if w in inside and w not in parent:
                parent[w] = v
                queue.append(w)
    raise AssertionError(f"no cycle through {start}")


def cycle_report(graph: dict, modules: dict, root: Path) -> list:
    """One line per cycle: ``a (a.py:12) -> b (b.py:3) -> a``, each arrow's import statement located."""
    lines = []
    for component in strongly_connected(graph):
        cycle = a_cycle(graph, component)
        steps = [f"{v} ({modules[v].relative_to(root).as_posix()}:{graph[v][w]})" for v, w in zip(cycle, cycle[1:])]
        lines.append(" -> ".join([*steps, cycle[-1]]) + (f"  [{len(component)} modules in the cycle's component]"
                                                         if len(component) > len(cycle) - 1 else ""))
    return lines


def test_no_import_cycles_between_modules():
    modules = _module_names(ROOT, FOLDERS)
    cycles = cycle_report(import_graph(modules), modules, ROOT)
    assert not cycles, "import cycles (break each by moving the shared piece down):\n" + "\n".join(cycles)


def test_the_graph_resolves_the_ways_a_module_is_named():
    modules = _module_names(ROOT, FOLDERS)
    assert modules["airmat.calib"] == ROOT / "calib" / "__init__.py"
    assert modules["airmat.synthetic.targets"] == ROOT / "data_synthetic" / "targets.py"
    graph = import_graph(modules)
    assert "airmat.cli.sigint" in graph["airmat.cli"]                 # from airmat.cli import sigint
    assert "airmat.lazy" in graph["airmat.calib"]                     # from airmat.lazy import attach
    assert not any(_is_under(d, "airmat.calib.") for d in graph["airmat.calib"])   # attached lazily: no edge


def _plant(root: Path, files: dict) -> dict:
    for name, text in files.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)
    return _module_names(root, {"pkg": "top.pkg"})


def test_the_cycle_check_finds_a_planted_cycle(tmp_path):
    # a -> b at the top, b -> c inside a function, c -> a by a relative import: one cycle of three;
    # the lazy __init__ names its submodules as strings only, d imports a but nothing imports d
    modules = _plant(tmp_path, {
        "pkg/__init__.py": "from airmat.lazy import attach\n\n"
                           "__getattr__, __dir__, __all__ = attach(__name__, {'a': ['f'], 'd': ['g']})\n",
        "pkg/a.py": "import numpy\nfrom top.pkg.b import g\n",
        "pkg/b.py": "def g():\n    from top.pkg import c\n    return c\n",
        "pkg/c.py": "import os\n\n\ndef h():\n    from . import a\n",
        "pkg/d.py": "from .a import f\nimport top.pkg\n",
    })
    graph = import_graph(modules)
    assert graph["top.pkg"] == {}
    assert graph["top.pkg.c"] == {"top.pkg.a": 5}
    assert graph["top.pkg.d"] == {"top.pkg.a": 1, "top.pkg": 2}
    assert strongly_connected(graph) == [["top.pkg.a", "top.pkg.b", "top.pkg.c"]]
    [line] = cycle_report(graph, modules, tmp_path)
    assert line == "top.pkg.a (pkg/a.py:2) -> top.pkg.b (pkg/b.py:2) -> top.pkg.c (pkg/c.py:5) -> top.pkg.a"
    # and once the shared piece moves down, the check passes
    (tmp_path / "pkg" / "c.py").write_text("import os\n")
    assert strongly_connected(import_graph(modules)) == []


def test_the_cycle_check_finds_a_cycle_through_a_package_init(tmp_path):
    modules = _plant(tmp_path, {"pkg/__init__.py": "from top.pkg.a import f\n",
                                "pkg/a.py": "from top.pkg import g\n\n\ndef f():\n    pass\n",
                                "pkg/sub/__init__.py": "",
                                "pkg/sub/b.py": "from ..a import f\nfrom .. import sub\n"})
    graph = import_graph(modules)
    assert graph["top.pkg.sub.b"] == {"top.pkg.a": 1, "top.pkg.sub": 2}
    assert strongly_connected(graph) == [["top.pkg", "top.pkg.a"]]


# --- no old top-level names ------------------------------------------------------------------------------------


def test_nothing_imports_the_old_top_level_names():
    """``calib``, ``design``, ... install as ``airmat.calib``, ...: an ``import calib`` works only from the
    repository's root, never for an installed user."""
    files = [*_files(*FOLDERS), *sorted((ROOT / "tests").rglob("*.py")), *sorted((ROOT / "bench").rglob("*.py"))]
    bad = [f"{p.relative_to(ROOT).as_posix()}:{line}: {m}" for p in files for line, m, _ in _imports(p)
           if m.split(".")[0] in OLD_TOP_LEVEL]
    assert not bad, "imports of the old top-level names (now airmat.calib, ...):\n" + "\n".join(bad)


def test_the_old_name_check_finds_one(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("import airmat.calib\nimport checkpoint\n\ndef f():\n    from report.page import Part\n")
    assert [m for _, m, _ in _imports(f) if m.split(".")[0] in OLD_TOP_LEVEL] == ["report.page"]


# --- which package may import which ----------------------------------------------------------------------------


def test_data_synthetic_imports_no_design():
    bad = [(p.relative_to(ROOT), m) for p in _files("data_synthetic") for m, _ in _imported_modules(p)
           if _is_under(m, "airmat.design")]
    assert bad == []


def test_product_imports_no_data_synthetic_outside_the_cli():
    # the CLI's synth/demo/gallery commands make test and demo data: that is their job
    files = [p for p in _files(*PRODUCT) if "cli" not in p.relative_to(ROOT).parts]
    bad = [(p.relative_to(ROOT), m) for p in files for m, _ in _imported_modules(p)
           if _is_under(m, "airmat.synthetic")]
    assert bad == []


def test_no_module_imports_another_modules_private_names():
    bad = [(p.relative_to(ROOT), m, n) for p in _files(*FOLDERS)
           for m, names in _imported_modules(p) for n in names if n.startswith("_") and not n.startswith("__")]
    assert bad == []


@pytest.mark.parametrize("module, forbidden", [("airmat.synthetic.targets", "airmat.design"),
                                               ("airmat.design.presets", "airmat.synthetic")])
def test_importing_does_not_load_the_other_package(module, forbidden):
    code = (f"import sys, {module}; "
            f"print(sorted(m for m in sys.modules if m == {forbidden!r} or m.startswith({forbidden + '.'!r})))")
    run = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                         env={"PYTHONPATH": str(ROOT), "PATH": ""})
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "[]"


#: what each package may import besides itself (docs/architecture.md); "airmat" is the shared core, the modules
#: directly in airmat/ (geometry included); airmat.cli (and airmat/__main__.py, which runs it) may import
#: everything and nothing may import it.
#: airmat/__init__.py's lazy facade names its targets as strings ("airmat.calib.scan_io:read_scan"): no imports.
ALLOWED = {
    "airmat": {"airmat"},
    "airmat.calib": {"airmat"},
    "airmat.design": {"airmat", "airmat.calib", "airmat.inflation"},   # U_A's Newton: the inflation's sparse Cholesky
    "airmat.inflation": {"airmat"},
    "airmat.check": {"airmat", "airmat.calib", "airmat.design", "airmat.inflation"},
    "airmat.synthetic": {"airmat", "airmat.calib"},
    "airmat.asbuilt": {"airmat", "airmat.calib", "airmat.design", "airmat.inflation", "airmat.check"},
    "airmat.report": {"airmat", "airmat.calib", "airmat.design", "airmat.check", "airmat.inflation", "airmat.asbuilt"},
}


def _layer(module: str) -> str | None:
    """The package of ALLOWED (or ``airmat.cli``) a module belongs to; None for another library's."""
    if _is_under(module, "airmat.cli") or module == "airmat.__main__":     # python -m airmat: the command
        return "airmat.cli"
    return max((p for p in ALLOWED if _is_under(module, p)), key=len, default=None)


def _imported_packages(path: Path) -> set:
    """Our packages that the file imports, including inside functions."""
    return {_layer(m) for m, _ in _imported_modules(path)} - {None}


def test_imports_point_one_way():
    bad = [f"{p.relative_to(ROOT).as_posix()} imports {dep}"
           for name, p in _product_modules().items() if _layer(name) != "airmat.cli"
           for dep in sorted(_imported_packages(p) - {_layer(name)} - ALLOWED[_layer(name)])]
    assert not bad, "imports against the dependency direction:\n" + "\n".join(bad)


def test_every_product_module_has_a_layer():
    assert {_layer(m) for m in _product_modules()} == {*ALLOWED, "airmat.cli"}
    assert _layer("airmat.geometry.grid") == "airmat" and _layer("airmat.lazy") == "airmat"
    assert _layer("airmat.synthetic.targets") == "airmat.synthetic" and _layer("numpy.linalg") is None
    assert _layer("airmat.__main__") == "airmat.cli" and _layer("airmat.cli.design") == "airmat.cli"


def test_the_direction_check_finds_a_wrong_import(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("import numpy\nfrom airmat.calib.model import kappa1\n\ndef f():\n    import airmat.check.compare\n"
                 "    from airmat.cli import main\n")
    assert _imported_packages(f) == {"airmat.calib", "airmat.check", "airmat.cli"}
