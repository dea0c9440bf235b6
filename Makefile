# navbench: `make all` runs the default (quick) pipeline, `make test` the test suite.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
PROFILE ?= quick

.PHONY: setup test all clean

setup: $(STAMP)

# Reinstalls only when pyproject.toml changes. torch==2.13.0 resolves to the CPU wheel on this
# machine; GPU users install their own torch build into the venv first (see README).
$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e ".[test]"
	touch $(STAMP)

test: setup
	$(BIN)/python -m pytest -q -n 2 --dist loadgroup tests

all: setup
	$(BIN)/navbench all --profile $(PROFILE)

clean:
	rm -rf results/cache results/report results/navbench.db .pytest_cache
	find . -name __pycache__ -type d -prune -exec rm -rf {} +
