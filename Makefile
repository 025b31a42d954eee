# sightplan — every dependency is installed by the project's own files.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: setup demo test lint bench clean

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e '.[dev]'
	touch $(STAMP)

setup: $(STAMP)

## Quick start 1: set up, then evaluate a ring of frames around the bundled Duplex model.
demo: $(STAMP)
	$(BIN)/sightplan evaluate sample --out sightplan-demo

## Quick start 2: set up, lint, and run the whole test suite.
test: $(STAMP)
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/python -m pytest -q

bench: $(STAMP)
	$(BIN)/python benchmarks/run.py

clean:
	rm -rf $(VENV) sightplan-demo .pytest_cache
