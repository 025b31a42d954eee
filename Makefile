# sightplan — every dependency is installed by the project's own files.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
PORT ?= 8000

.PHONY: setup demo test test-loaded docs lint bench clean wheel wheel-check

# System packages, from Debian's archive when missing (as root; otherwise a note says what to install):
# - EGL: the OpenGL engine renders headless, on a GPU's driver or on Mesa's llvmpipe;
# - chromium: the browser the tests open the HTML report in;
# - npm: three.js for the report's 3D view;
# - postgresql: the tests run the web server on a throw-away PostgreSQL cluster too;
# - proj-data: the EGM96 geoid grid, for the WGS84 ellipsoidal heights of WPML and GeoJSON exports.

$(STAMP): pyproject.toml web/package.json
	@missing=""; \
	ldconfig -p | grep -q 'libEGL_mesa.so.0\|libEGL_nvidia.so.0' || missing="libegl1 libegl-mesa0 libgl1-mesa-dri"; \
	command -v chromium >/dev/null || missing="$$missing chromium"; \
	command -v npm >/dev/null || missing="$$missing npm"; \
	ls /usr/lib/postgresql/*/bin/initdb >/dev/null 2>&1 || missing="$$missing postgresql"; \
	ls /usr/share/proj/egm96_15.gtx >/dev/null 2>&1 || ls /usr/share/proj/us_nga_egm96_15.tif >/dev/null 2>&1 || missing="$$missing proj-data"; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends $$missing; \
	  else echo "note: install these Debian packages for every feature and test: $$missing"; fi; \
	fi
	$(PY) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e '.[all,dev]'
	@# three.js for the HTML report's 3D view, from the npm registry, pinned by web/package-lock.json
	if [ -f web/package-lock.json ]; then npm ci --prefix web --no-audit --no-fund; \
	else npm install --prefix web --no-audit --no-fund; fi
	touch $(STAMP)

setup: $(STAMP)

## Quick start 1: set up, plan a facade grid around the bundled Duplex model, check it can be flown, evaluate it,
## then serve the web application with that sample project ready (Ctrl-C stops it).
demo: $(STAMP)
	mkdir -p sightplan-demo
	$(BIN)/sightplan plan facade sample --safety-distance 8 --overlap 0.8 -o sightplan-demo/plan.json
	$(BIN)/sightplan evaluate sample sightplan-demo/plan.json --scale 0.25 --out sightplan-demo
	$(BIN)/sightplan serve --data sightplan-demo/server --sample --port $(PORT)

## Quick start 2: set up, lint, build the documentation (strict: a broken link fails), and run the whole test suite.
test: $(STAMP)
	$(BIN)/ruff check src tests benchmarks mkdocs_hooks.py setup.py
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict -q
	$(BIN)/python -m pytest -q

## The whole suite again with every core kept busy by other processes (twice as many as cores): nothing may flake.
test-loaded: $(STAMP)
	$(BIN)/python benchmarks/under_load.py -- $(MAKE) --no-print-directory test

## The documentation site, from docs/ (MkDocs, Material theme) into site/.
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict

## A wheel that carries the page's JavaScript (copied from web/node_modules at build time), in dist/.
wheel: $(STAMP)
	$(BIN)/python -m pip wheel -q --no-deps -w dist .

## The wheel installed alone in a fresh environment serves the page and /docs (a test of make test, alone).
wheel-check: $(STAMP)
	$(BIN)/python -m pytest -q -m wheel tests/test_wheel.py

bench: $(STAMP)
	$(BIN)/python -m pytest -q -m bench
	$(BIN)/python benchmarks/speed.py
	$(BIN)/python benchmarks/load.py
	$(BIN)/python benchmarks/lean.py
	$(BIN)/python benchmarks/features.py
	$(BIN)/python benchmarks/run.py
	$(BIN)/python benchmarks/planning.py
	$(BIN)/python benchmarks/checks.py
	$(BIN)/python benchmarks/replay.py
	$(BIN)/python benchmarks/validation.py
	$(BIN)/python benchmarks/large.py
	$(BIN)/python benchmarks/pointcloud.py
	$(BIN)/python benchmarks/optimize.py
	$(BIN)/python benchmarks/ties.py
	$(BIN)/python benchmarks/loop.py
	$(BIN)/python benchmarks/predict.py
	$(BIN)/python benchmarks/robustness.py

clean:
	rm -rf $(VENV) site sightplan-demo sightplan-out sightplan-progress sightplan-study sightplan-validate .pytest_cache
