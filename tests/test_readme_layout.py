"""The README's Layout section names every module of the product packages (it is how a newcomer finds them)."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("airmat", "calib", "design", "inflation", "check", "report", "data_synthetic")


def _layout() -> str:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("## Layout", 1)[1]
    return section.split("```", 2)[1]


def test_every_module_is_in_the_layout():
    layout = _layout()
    names = set(re.findall(r"[A-Za-z_][A-Za-z0-9_]*", layout))
    missing = sorted(str(p.relative_to(ROOT)) for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py")
                     if p.stem != "__init__" and p.stem not in names)
    assert not missing, "modules missing from README's Layout: " + ", ".join(missing)


def test_the_layout_names_no_module_that_is_gone():
    layout = _layout()
    listed = set(re.findall(r"([A-Za-z_][A-Za-z0-9_]*)\.py", layout))
    present = {p.stem for folder in (*PACKAGES, "tests", "bench") for p in (ROOT / folder).rglob("*.py")}
    assert not (listed - present), f"README's Layout names modules that do not exist: {sorted(listed - present)}"
