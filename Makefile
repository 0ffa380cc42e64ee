# Two commands on a fresh Debian machine with Python 3.11 (as root):
#   make demo   -- set everything up on first use, then run the whole pipeline on embedded defaults
#   make test   -- set everything up on first use, then run the full test suite (what CI runs)
#   make docs   -- the Sphinx site in docs/_build/html (installs the docs extra on first use; warnings fail it)
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp
OUT    ?= out/demo

.PHONY: demo test test-fast bench docs setup clean

setup: $(STAMP)

$(STAMP): pyproject.toml scripts/bootstrap.sh
	@bash scripts/bootstrap.sh $(VENV)
	@touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/airmat demo --out $(OUT)

# the suite's tests are independent: one worker process per core, at most 4 (pytest-xdist; work stealing
# evens out the long end-to-end tests)
XDIST  := -n auto --maxprocesses 4 --dist worksteal

test: $(STAMP)
	$(PY) -m pytest -q $(XDIST)

test-fast: $(STAMP)
	$(PY) -m pytest -q $(XDIST) -m "not slow"

bench: $(STAMP)
	$(PY) -m pip install -q -e ".[bench]"
	$(PY) bench/run_all.py

# the docs extra (sphinx, myst-parser, furo) once, again when pyproject.toml changes; -W: a warning fails the build
DOCS_STAMP := $(VENV)/.docs-stamp

$(DOCS_STAMP): $(STAMP) pyproject.toml
	$(PY) -m pip install -q -e ".[docs]"
	@touch $(DOCS_STAMP)

docs: $(DOCS_STAMP)
	$(VENV)/bin/sphinx-build -W --keep-going -b html docs docs/_build/html

clean:
	rm -rf $(VENV) out build *.egg-info docs/_build
