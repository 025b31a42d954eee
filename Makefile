# sightplan — every dependency is installed by the project's own files.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: setup demo test lint bench clean

# The OpenGL engine renders headless through EGL: a GPU's driver, or Mesa's llvmpipe on the CPU.
EGL_PACKAGES := libegl1 libegl-mesa0 libgl1-mesa-dri

$(STAMP): pyproject.toml web/package.json
	@if ! ldconfig -p | grep -q 'libEGL_mesa.so.0\|libEGL_nvidia.so.0'; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends $(EGL_PACKAGES); \
	  else echo "note: no EGL driver found; install $(EGL_PACKAGES) for the gl engine"; fi; \
	fi
	$(PY) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e '.[dev]'
	@# three.js for the HTML report's 3D view, from the npm registry, pinned by web/package-lock.json
	@if ! command -v npm >/dev/null && [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	  apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends npm; \
	fi
	if [ -f web/package-lock.json ]; then npm ci --prefix web --no-audit --no-fund; \
	else npm install --prefix web --no-audit --no-fund; fi
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
	$(BIN)/python benchmarks/large.py

clean:
	rm -rf $(VENV) sightplan-demo sightplan-out sightplan-progress sightplan-study sightplan-validate .pytest_cache
