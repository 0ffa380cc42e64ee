"""The documentation stays what it promises: the Layout names every module, the README is short, no page or source file narrates history."""

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("airmat", "calib", "design", "inflation", "check", "report", "data_synthetic", "asbuilt")
README_MAX_LINES = 300
#: phrases of a measurement history; CHANGELOG.md is where history belongs
HISTORY = re.compile(r"\bsession \d+|was measured in session", re.IGNORECASE)
#: markers of work history in a comment or docstring: a session, an issue's number
PY_HISTORY = re.compile(r"\bsession \d+|\(issue \d+\)|\bissue \d+'s\b", re.IGNORECASE)
#: a pointer to the README for a measurement or an explanation; they live in docs/
README_POINTER = re.compile(r"README,|in the README|see the README", re.IGNORECASE)


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


def _tracked_python(*folders: str) -> list[Path]:
    """The tracked .py files under ``folders`` (``git ls-files``)."""
    try:
        out = subprocess.run(["git", "ls-files", "-z", "--", *(f"{f}/*.py" for f in folders)], cwd=ROOT,
                             capture_output=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    return [ROOT / name for name in out.decode("utf-8").split("\0") if name]


def _lines_matching(paths: list[Path], pattern: re.Pattern) -> list[str]:
    found = []
    for path in paths:
        if not path.is_file():
            continue
        for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if pattern.search(line):
                found.append(f"{path.relative_to(ROOT).as_posix()}:{i}: {line.strip()[:100]}")
    return found


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


def test_no_python_file_narrates_history():
    files = _tracked_python(*PACKAGES, "tests", "bench")
    assert files
    found = _lines_matching(files, PY_HISTORY)
    assert not found, ("comments and docstrings say what the code does and why; history belongs in "
                       "CHANGELOG.md:\n" + "\n".join(found))


def test_no_product_file_points_to_the_readme():
    files = _tracked_python(*PACKAGES)
    assert files
    found = _lines_matching(files, README_POINTER)
    assert not found, ("measurements live in docs/benchmarks.md (under their command), experiments in "
                       "docs/decisions.md, explanations in docs/guide/ and docs/method.md:\n" + "\n".join(found))
