# Two commands on a fresh machine:  `make demo`  and  `make test`.
PY ?= python3
# the suite runs on 2 pytest-xdist workers (CI has 2 cores; many tests wait on services); loadscope keeps a module's
# tests on one worker, so a module's expensive fixture (a live service, trained ROMs) is built once; PYTEST_ARGS= runs
# it serially. (loadgroup would be finer, but pytest-xdist 3.8 cannot tag node ids under pytest 9.)
PYTEST_ARGS ?= -n 2 --dist loadscope
VENV ?= .venv
BIN := $(VENV)/bin

.PHONY: install demo test lint bench docs

$(BIN)/romams: pyproject.toml client/pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e '.[dev]'
	$(BIN)/pip install -q -e client/  # romams-client (import romams_client): the client as its own distribution
	$(BIN)/pip install -q --no-deps 'pyNastran==1.4.1' 'cpylog>=1.5' || echo "pyNastran not installed: Nastran OP2/BDF support disabled"
	$(BIN)/python -c "from romams_core.flutter.newton_kernel import warm_up; warm_up()"  # numba's cache of the tracker
	$(BIN)/python -c "from romams_core.aero.dlm_kernel import warm_up; warm_up()"  # and of the DLM kernel
	touch $(BIN)/romams

install: $(BIN)/romams

demo: install
	$(BIN)/romams demo --out demo-out $(DEMO_ARGS)

test: install
	$(BIN)/ruff check .
	$(BIN)/lint-imports
	$(BIN)/mypy romams_core
	$(BIN)/python -m pytest $(PYTEST_ARGS)

lint: install
	$(BIN)/ruff check .

bench: install
	$(BIN)/python -m benchmarks.run --json

# the user docs (MkDocs, docs/ + mkdocs.yml) into site/; --strict: any warning (a broken link, an anchor) fails;
# the HTTP API reference page is generated from the OpenAPI document on every build (docs/hooks.py)
docs: install
	$(BIN)/mkdocs build --strict --site-dir site
