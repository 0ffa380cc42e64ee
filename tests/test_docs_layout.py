"""The documentation stays what it promises: the Layout names every module, the README is short, no page narrates history."""

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("airmat", "calib", "design", "inflation", "check", "report", "data_synthetic")
README_MAX_LINES = 300
#: phrases of a measurement history; CHANGELOG.md is where history belongs
HISTORY = re.compile(r"\bsession \d+|was measured in session", re.IGNORECASE)


def _layout() -> str:
    """The first code block after docs/architecture.md's "## Layout" heading."""
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    section = text.split("## Layout", 1)[1]
    return section.split("```", 2)[1]


def _tracked_markdown() -> list[Path]:
    try:
        out = subprocess.run(["git", "ls-files", "-z", "*.md"], cwd=ROOT, capture_output=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    return [ROOT / name for name in out.decode("utf-8").split("\0") if name]


def test_every_module_is_in_the_layout():
    layout = _layout()
    names = set(re.findall(r"[A-Za-z_][A-Za-z0-9_]*", layout))
    missing = sorted(str(p.relative_to(ROOT)) for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py")
                     if p.stem != "__init__" and p.stem not in names)
    assert not missing, "modules missing from docs/architecture.md's Layout: " + ", ".join(missing)


def test_the_layout_names_no_module_that_is_gone():
    layout = _layout()
    listed = set(re.findall(r"([A-Za-z_][A-Za-z0-9_]*)\.py", layout))
    present = {p.stem for folder in (*PACKAGES, "tests", "bench") for p in (ROOT / folder).rglob("*.py")}
    assert not (listed - present), f"docs/architecture.md's Layout names modules that do not exist: {sorted(listed - present)}"


def test_readme_is_short():
    n = len((ROOT / "README.md").read_text(encoding="utf-8").splitlines())
    assert n <= README_MAX_LINES, f"README.md has {n} lines, at most {README_MAX_LINES}: move detail into docs/"


def test_no_history_outside_the_changelog():
    found = []
    for path in _tracked_markdown():
        if path.name == "CHANGELOG.md" or not path.is_file():
            continue
        for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if HISTORY.search(line):
                found.append(f"{path.relative_to(ROOT)}:{i}: {line.strip()[:80]}")
    assert not found, "history belongs in CHANGELOG.md:\n" + "\n".join(found)
