"""Sphinx configuration of the airmat documentation (``make docs``).

Pages are Markdown (MyST); the API reference is autodoc on the numpydoc
docstrings (napoleon), the CLI reference is generated from the argparse parser
by the local extension ``_ext/airmat_sphinx.py``. The build needs no network:
no intersphinx, and math is rendered by MathJax in the reader's browser.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))
# airmat is installed (editable) in the venv that runs sphinx-build; from a plain checkout
# the root package still imports (the stage folders need the install's package-dir mapping)
sys.path.append(str(HERE.parent))
# the same one-BLAS-thread default the package sets, before autodoc imports numpy
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
os.environ.setdefault("MPLBACKEND", "Agg")

import airmat  # noqa: E402

project = "airmat"
author = "airmat contributors"
copyright = "airmat contributors"
release = airmat.__version__
version = ".".join(release.split(".")[:2])

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.viewcode",
    "sphinx.ext.mathjax",
    "airmat_sphinx",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "_ext", "Thumbs.db", ".DS_Store"]
templates_path: list[str] = []

# MyST: $...$ / $$...$$ math, ::: fences, anchors for ## and ### headings ([text](page.md#anchor))
myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 3

# autodoc + napoleon (numpydoc-style docstrings)
autodoc_default_options = {"members": True, "member-order": "bysource"}
autodoc_typehints = "signature"
autodoc_preserve_defaults = True
autoclass_content = "class"
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_rtype = False
napoleon_use_ivar = True

# furo if the docs extra is installed, else a built-in theme
try:
    import furo  # noqa: F401
    html_theme = "furo"
except ImportError:  # pragma: no cover
    html_theme = "alabaster"
html_title = f"airmat {release}"
html_static_path: list[str] = []
html_show_sourcelink = False

