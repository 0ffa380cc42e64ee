"""The Examples sections of every module's docstrings, run by import name (``airmat.calib.model``, ...).

The modules are imported under the one import root ``airmat`` as an installed user imports them, never
as top-level ``calib`` or ``design`` from the repository's folders.
"""

import doctest
import importlib
import pkgutil

import pytest

def _all_modules():
    import airmat.calib, airmat.design, airmat.inflation, airmat.check, airmat.report  # noqa: E401,F401
    import airmat.synthetic, airmat.asbuilt  # noqa: E401,F401
    names = set()
    for pkg in ("airmat", "airmat.calib", "airmat.design", "airmat.inflation", "airmat.check", "airmat.report",
                "airmat.synthetic", "airmat.asbuilt"):
        module = importlib.import_module(pkg)
        names.add(pkg)
        names |= {m.name for m in pkgutil.walk_packages(module.__path__, pkg + ".")
                  if not m.name.endswith("__main__")}
    return sorted(names)


@pytest.mark.parametrize("name", _all_modules())
def test_docstring_examples(name):
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    tests = [t for t in finder.find(module, name) if t.examples]
    for t in tests:
        runner.run(t)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed in {name}"
