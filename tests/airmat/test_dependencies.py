"""Dependencies point one way: the product does not import the test data, nor private names."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PRODUCT = ("airmat", "calib", "design", "inflation", "check", "report")


def _imports(path: Path):
    """(module, names) of every import statement in a file."""
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield a.name, []
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            yield node.module, [a.name for a in node.names]


def _files(*packages):
    return [p for pkg in packages for p in sorted((ROOT / pkg).rglob("*.py"))]


def test_data_synthetic_imports_no_design():
    bad = [(p.relative_to(ROOT), m) for p in _files("data_synthetic") for m, _ in _imports(p)
           if m == "design" or m.startswith("design.")]
    assert bad == []


def test_product_imports_no_data_synthetic_outside_the_cli():
    # the CLI's synth/demo/gallery commands make test and demo data: that is their job
    files = [p for p in _files(*PRODUCT) if "cli" not in p.relative_to(ROOT).parts]
    bad = [(p.relative_to(ROOT), m) for p in files for m, _ in _imports(p)
           if m == "data_synthetic" or m.startswith("data_synthetic.")]
    assert bad == []


def test_no_module_imports_another_modules_private_names():
    bad = [(p.relative_to(ROOT), m, n) for p in _files(*PRODUCT, "data_synthetic")
           for m, names in _imports(p) for n in names if n.startswith("_") and not n.startswith("__")]
    assert bad == []


@pytest.mark.parametrize("module, forbidden", [("airmat.synthetic.targets", "design"),
                                               ("airmat.design.presets", "data_synthetic")])
def test_importing_does_not_load_the_other_package(module, forbidden):
    code = (f"import sys, {module}; "
            f"print(sorted(m for m in sys.modules if m == {forbidden!r} or m.startswith({forbidden + '.'!r})))")
    run = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                         env={"PYTHONPATH": str(ROOT), "PATH": ""})
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "[]"


#: what each package may import besides itself (docs/architecture.md); airmat.cli may import everything
ALLOWED = {
    "airmat": {"airmat"},
    "calib": {"airmat"},
    "design": {"airmat", "calib"},
    "inflation": {"airmat"},
    "check": {"airmat", "calib", "design", "inflation"},
    "data_synthetic": {"airmat", "calib"},
    "report": {"airmat", "calib", "design", "check", "inflation"},
}


def _imported_packages(path: Path) -> set:
    """Top-level names of our packages that the file imports, including inside functions."""
    return {m.split(".")[0] for m, _ in _imports(path)} & set(ALLOWED)


def test_imports_point_one_way():
    bad = [f"{p.relative_to(ROOT).as_posix()} imports {dep}"
           for pkg in ALLOWED for p in _files(pkg) if "cli" not in p.relative_to(ROOT).parts
           for dep in sorted(_imported_packages(p) - {pkg} - ALLOWED[pkg])]
    assert not bad, "imports against the dependency direction:\n" + "\n".join(bad)


def test_the_direction_check_finds_a_wrong_import(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("import numpy\nfrom airmat.calib.model import kappa1\n\ndef f():\n    import airmat.check.compare\n")
    assert _imported_packages(f) == {"calib", "check"}
