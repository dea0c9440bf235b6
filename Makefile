# navbench: `make all` runs the default (quick) pipeline, `make test` the test suite.
PYTHON  ?= python3
VENV    ?= .venv
BIN     := $(VENV)/bin
STAMP   := $(VENV)/.installed
PROFILE ?= quick
# numba's compiled kernels are cached here, so only the first run pays for compilation
export NUMBA_CACHE_DIR ?= $(CURDIR)/.numba_cache

.PHONY: setup test all paper acceptance docs docs-serve clean

setup: $(STAMP)

# Reinstalls only when pyproject.toml or constraints.txt changes. constraints.txt pins exactly
# torch==2.13.0, which resolves to the CPU wheel on this machine; GPU users install their own
# torch build into the venv first (see docs/getting-started.md).
$(STAMP): pyproject.toml constraints.txt
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -c constraints.txt -e ".[test,ray,postgres,docs,vizdoom]"
	touch $(STAMP)

test: setup
	$(BIN)/python -m pytest -q -n 2 --dist loadgroup tests

# The whole pipeline of a profile (make-level -> collect-views -> fit-map -> sample-tasks ->
# run-navigation -> score -> report), every stage cached: a rerun only verifies the cache.
all: setup
	$(BIN)/navbench all --profile $(PROFILE)

# The paper's protocol: six levels, 5000 views, 10 000 fit steps, 200 tasks, three noise levels.
paper: setup
	$(BIN)/navbench all --profile paper

# The acceptance grid of a candidate benchmark version (docs/changelog.md): the same grid under
# navbench-1 and the candidate (CANDIDATE=navbench-5 by default), one database each, then their
# paired differences and the verdict (compare --acceptance exits 1 when it is not accepted).
# The candidate's run reuses navbench-1's views and maps where its settings leave them alone.
CANDIDATE ?= navbench-5
acceptance: setup
	$(BIN)/navbench all --profile acceptance --benchmark-version navbench-1 --db sqlite:///results/acceptance-1.db --report results/acceptance-1
	$(BIN)/navbench all --profile acceptance --benchmark-version $(CANDIDATE) --db sqlite:///results/acceptance-$(CANDIDATE).db --report results/acceptance-$(CANDIDATE)
	$(BIN)/navbench compare --acceptance --db sqlite:///results/acceptance-1.db --b-db sqlite:///results/acceptance-$(CANDIDATE).db --format markdown

# The documentation site (MkDocs + Material, mkdocs.yml): built into site/, or served with live reload
# at http://127.0.0.1:8000. --strict: a broken link, a missing anchor or a page left out of the
# navigation fails the build (tests/docs/test_docs_build.py runs the same build).
docs: setup
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --site-dir site

docs-serve: setup
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs serve

clean:
	rm -rf results/cache results/report results/navbench.db .pytest_cache .numba_cache site
	find . -name __pycache__ -type d -prune -exec rm -rf {} +
