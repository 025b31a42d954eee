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

## Quick start 1: set up, plan a facade grid around the bundled Duplex model, check it can be flown, evaluate it.
demo: $(STAMP)
	mkdir -p sightplan-demo
	$(BIN)/sightplan plan facade sample --safety-distance 8 --overlap 0.8 -o sightplan-demo/plan.json
	$(BIN)/sightplan evaluate sample sightplan-demo/plan.json --scale 0.25 --out sightplan-demo

## Quick start 2: set up, lint, and run the whole test suite.
test: $(STAMP)
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/python -m pytest -q

bench: $(STAMP)
	$(BIN)/python benchmarks/run.py
	$(BIN)/python benchmarks/planning.py
	$(BIN)/python benchmarks/validation.py

clean:
	rm -rf $(VENV) sightplan-demo sightplan-out sightplan-progress sightplan-study sightplan-validate .pytest_cache
